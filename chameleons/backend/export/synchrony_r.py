"""The synchrony section of ``analysis.R`` (issue 32), appended after the main analysis:
fidelity by condition (the robot following the participant, the copy checks) and the
participant's mimicry as an outcome (``lmer``) and as a covariate of each questionnaire
score, as :mod:`chameleons.experiment.stats.synchrony.outcomes` computes them in Python.
It reads the synchrony columns of ``interactions.csv``; an export without them skips it."""

SYNCHRONY_R = r"""
# ---- Synchrony of the faces (issue 32): docs/science.md "Synchrony" ----
# sync_*: the robot following the participant (did the manipulation run?); mimicry_r: the
# participant following the robot, surrogate-corrected; mimicry_z = atanh(mimicry_r).
synchrony_section <- function(interactions, scores) {
  if (!("mimicry_r" %in% names(interactions))) return(invisible(NULL))
  cat("\n---- Synchrony: the robot following the participant, the participant's mimicry ----\n")
  for (condition in conditions) {
    rows <- interactions[interactions$condition == condition, ]
    checks <- table(factor(rows$sync_check, levels = c("ok", "failed")))
    cat(sprintf(paste("synchrony %-10s %d interactions: sync_r mean %.4f (n = %d),",
                      "sync_lag_s median %.3f, mimicry_r mean %.4f (n = %d),",
                      "copy checks ok %d, failed %d\n"),
                condition, nrow(rows), mean(rows$sync_r, na.rm = TRUE), sum(!is.na(rows$sync_r)),
                median(rows$sync_lag_s, na.rm = TRUE), mean(rows$mimicry_r, na.rm = TRUE),
                sum(!is.na(rows$mimicry_r)), checks[["ok"]], checks[["failed"]]))
  }
  missing <- table(interactions$sync_missing[!is.na(interactions$sync_missing)])
  if (length(missing) > 0) print(missing)
  data <- interactions[!is.na(interactions$mimicry_r) & abs(interactions$mimicry_r) < 1,
                       c("participant", "condition", "position", "mimicry_r")]
  if (nrow(data) < 6 || length(unique(data$participant)) < 2) {
    cat("Too few interactions with mimicry values for the models.\n")
    return(invisible(NULL))
  }
  data$mimicry_z <- atanh(data$mimicry_r)
  # A still robot has no mimicry (nothing moved): then the first condition with values.
  baseline <- if (reference %in% data$condition) reference else sort(unique(data$condition))[1]
  outcome <- data
  outcome$condition <- relevel(factor(outcome$condition), ref = baseline)
  outcome$position <- factor(outcome$position)
  model <- fit_lmm(mimicry_z ~ condition + position + (1 | participant), data = outcome,
                   REML = TRUE)
  cat("\nmimicry_z (linear mixed model)\n")
  print(summary(model))
  estimates <- summary(model)$coefficients
  for (term in rownames(estimates)) {
    cat(sprintf("mimicry_z coefficient %s = %.6f (SE %.6f)\n", term, estimates[term, 1],
                estimates[term, 2]))
  }
  for (measure in questionnaires) {
    joined <- merge(data, scores[!is.na(scores[[measure]]), c("participant", "position", measure)],
                    by = c("participant", "position"))
    if (nrow(joined) < 6 || length(unique(joined$participant)) < 2) next
    joined$condition <- relevel(factor(joined$condition), ref = baseline)
    joined$position <- factor(joined$position)
    right <- "~ condition + position + mimicry_z + (1 | participant)"
    covariate <- fit_lmm(as.formula(paste(measure, right)), data = joined, REML = TRUE)
    estimates <- summary(covariate)$coefficients
    cat(sprintf("%s ~ mimicry_z: %.6f (SE %.6f), n = %d\n", measure,
                estimates["mimicry_z", 1], estimates["mimicry_z", 2], nrow(joined)))
  }
}
synchrony_section(interactions, scores)
"""
