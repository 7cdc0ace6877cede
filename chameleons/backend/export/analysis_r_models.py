"""The R code of ``analysis.R`` after its tests (:mod:`.analysis_r_tests`): ``MODELS``, the
acceptance models (total effect; kind-adjusted secondary), the score and item models and
the plots. A model that cannot be fitted prints why and the script goes on.
"""

MODELS = r"""
# ---- Acceptance of each suggestion ----
# Primary: the condition's total effect (no suggestion kind: the kind depends on earlier
# acceptances, a mediator). Secondary, labelled: the same adjusted for the kind.
accepted <- merge(suggestions[!is.na(suggestions$accepted), ],
                  interactions[, c("participant", "session", "position", "item_set",
                                   "condition")],
                  by = c("participant", "session", "position"), suffixes = c(".run", ""))
accepted <- accepted[accepted$condition %in% conditions, ]
fit_acceptance <- function(terms, title) {
  cat("\n", title, "\n", sep = "")
  if (length(unique(accepted$participant)) < 2) stop("needs at least two participants")
  if (length(unique(accepted$accepted)) < 2) stop("every decided suggestion has the same outcome")
  data <- accepted
  data$condition <- relevel(factor(data$condition), ref = reference)
  data$position <- factor(data$position)
  data$item_set <- factor(data$item_set)
  data$kind <- relevel(factor(data$kind, levels = c("optimal", "random")), ref = "optimal")
  data$kind <- droplevels(data$kind)
  terms <- terms[sapply(terms, function(term) nlevels(data[[term]]) > 1)]
  if (!("condition" %in% terms)) stop("needs suggestions in at least two conditions")
  right <- paste(terms, collapse = " + ")
  # Subject-specific odds ratios (a binomial mixed model): larger than the Python GEE's
  # population-averaged ones when participants differ.
  glmm <- lme4::glmer(as.formula(paste("accepted ~", right, "+ (1 | participant)")),
                      data = data, family = binomial)
  print(summary(glmm))
  if (requireNamespace("geepack", quietly = TRUE)) {
    data <- data[order(data$participant), ]
    data$cluster <- as.integer(factor(data$participant))
    gee <- geepack::geeglm(as.formula(paste("accepted ~", right)), id = cluster,
                           data = data, family = binomial, corstr = "exchangeable")
    print(summary(gee))
  }
}
guarded("acceptance model", fit_acceptance(
  c("condition", "position", "item_set"),
  "Acceptance: total effect of condition (accepted ~ condition + position + item_set)"))
guarded("kind-adjusted acceptance model", fit_acceptance(
  c("condition", "position", "item_set", "kind"),
  "Acceptance adjusted for suggestion kind (secondary: the kind is a mediator)"))

# ---- Questionnaire scores: linear mixed models ----
fit_lmm <- if (requireNamespace("lmerTest", quietly = TRUE)) lmerTest::lmer else lme4::lmer
for (measure in questionnaires) {
  guarded(paste(measure, "model"), {
    data <- scores[!is.na(scores[[measure]]) & scores$condition %in% conditions, ]
    if (length(unique(data$participant)) < 2) stop("needs at least two participants")
    data$condition <- relevel(factor(data$condition), ref = reference)
    data$position <- factor(data$position)
    terms <- c("condition", "position")
    terms <- terms[sapply(terms, function(term) nlevels(data[[term]]) > 1)]
    if (!("condition" %in% terms)) stop("needs scores in at least two conditions")
    formula <- paste(measure, "~", paste(terms, collapse = " + "), "+ (1 | participant)")
    model <- fit_lmm(as.formula(formula), data = data, REML = TRUE)
    cat("\n", measure, "\n")
    print(summary(model))
    if (requireNamespace("lmerTest", quietly = TRUE)) print(anova(model))
  })
}

# ---- Questionnaire items: cumulative link mixed models (ordinal) ----
items <- merge(questionnaire[!is.na(questionnaire$scored_value) &
                               questionnaire$questionnaire %in% questionnaires, ],
               interactions[, c("participant", "session", "position", "condition")],
               by = c("participant", "session", "position"), suffixes = c(".run", ""))
for (measure in questionnaires) {
  guarded(paste(measure, "item model"), {
    data <- items[items$questionnaire == measure & items$condition %in% conditions, ]
    if (length(unique(data$participant)) < 2) stop("needs at least two participants")
    if (length(unique(data$scored_value)) < 2) stop("every answer is the same")
    data$answer <- factor(data$scored_value, ordered = TRUE)
    data$condition <- relevel(factor(data$condition), ref = reference)
    data$position <- factor(data$position)
    data$participant <- factor(data$participant)
    data$item <- factor(data$item)
    model <- ordinal::clmm(answer ~ condition + position + (1 | participant) + (1 | item),
                           data = data)
    cat("\n", measure, "items (cumulative link mixed model)\n")
    print(summary(model))
  })
}

# ---- Plots: per measure, a box per condition and a line per participant ----
pdf(file.path(folder, "analysis-plots.pdf"), width = 5, height = 4.2)
plot_measure <- function(measure) {
  values <- complete_values(scores, measure)
  limits <- c(if (measure == "accepted") 0 else 1, scale_high[[measure]])
  if (nrow(values) == 0) {
    plot.new()
    title(main = sprintf("%s: no participant with a value in every condition", measure))
    return(invisible(NULL))
  }
  boxplot(values, names = condition_labels, ylim = limits, border = "#1f6feb",
          main = sprintf("%s (n = %d)", measure, nrow(values)), ylab = measure)
  matlines(t(values), col = adjustcolor("#5b6575", 0.45), lty = 1)
  points(seq_along(conditions), colMeans(values), pch = 18, col = "#b42318", cex = 1.6)
}
for (measure in measures) guarded(paste(measure, "plot"), plot_measure(measure))
invisible(dev.off())
cat("\nPlots written to", file.path(folder, "analysis-plots.pdf"), "\n")
"""
