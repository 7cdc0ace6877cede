"""The R code of ``analysis.R`` after its settings and reads (see :mod:`.analysis_r`), its
first half: ``TESTS``, the views, the Friedman tests with the exact permutation p, post-hoc
tests, effect sizes, Cronbach's alpha and the suggestion mix (the models follow, in
:mod:`.analysis_r_models`). Every section runs on any export: too few participants or a
model that cannot be fitted prints why and the script goes on. The lines the tests compare
with the Python analysis start with the measure or with ``effect``, ``alpha`` and ``mix``.
"""

TESTS = r"""
# ---- Helpers ----
format_p <- function(p) {
  if (length(p) == 0 || is.na(p)) return("undefined")
  if (p < 0.0001) "< 0.0001" else sprintf("%.4f", p)
}
# "p = 0.0123", "p < 0.0001" (never "p = 0.0000"), "p undefined".
p_is <- function(p) {
  text <- format_p(p)
  if (startsWith(text, "<") || text == "undefined") text else paste("=", text)
}
format_number <- function(x, digits) {
  if (length(x) == 0 || is.na(x)) "undefined" else sprintf(paste0("%.", digits, "f"), x)
}
# A section that fails (too few participants, a model that cannot be fitted) says why and
# the script goes on.
guarded <- function(what, expr) {
  tryCatch(expr, error = function(e) {
    cat(sprintf("%s not available: %s\n", what, conditionMessage(e)))
    invisible(NULL)
  })
}
view_title <- if (view == "as_planned") "as planned (intention to treat)" else
  "as run (per protocol: participants with deviations left out)"
cat("Analysed", view_title, "\n")

# ---- Participants: excluded ones leave every analysis; as run, so do deviations ----
excluded <- unique(scores$participant[scores$excluded %in% TRUE])
deviating <- character(0)
if (view == "as_run") {
  deviates <- scores$deviation %in% TRUE |
    (!is.na(scores$planned_condition) & scores$planned_condition != scores$condition)
  deviating <- setdiff(unique(scores$participant[deviates]), excluded)
}
if (length(excluded) > 0) cat("Excluded:", excluded, "\n")
if (length(deviating) > 0) cat("Left out for a deviation from the plan:", deviating, "\n")
left_out <- c(excluded, deviating)
scores <- scores[!(scores$participant %in% left_out), ]
suggestions <- suggestions[!(suggestions$participant %in% left_out), ]
interactions <- interactions[!(interactions$participant %in% left_out), ]
questionnaire <- questionnaire[!(questionnaire$participant %in% left_out), ]

# The condition each interaction counts for: as planned, the planned one where the file
# has one; as run, the one that ran.
view_condition <- function(planned, ran) {
  if (view == "as_planned") ifelse(is.na(planned), ran, planned) else ran
}
scores$condition <- view_condition(scores$planned_condition, scores$condition)
interactions$condition <- view_condition(interactions$planned_condition, interactions$condition)
participants <- sort(unique(scores$participant))
cat(length(participants), "participant(s) analysed\n")

# One row per participant with a value in every condition, one column per condition.
complete_values <- function(data, column) {
  data <- data[!is.na(data[[column]]) & data$condition %in% conditions, ]
  people <- sort(unique(data$participant))
  values <- matrix(NA_real_, nrow = length(people), ncol = length(conditions),
                   dimnames = list(people, conditions))
  values[cbind(match(data$participant, people), match(data$condition, conditions))] <-
    data[[column]]
  values[stats::complete.cases(values), , drop = FALSE]
}

# ---- The Friedman test, its exact permutation p and Kendall's W ----
# R's friedman.test drops a one-row matrix to a vector, so a single participant is
# computed from the same formula (tie-corrected); no participant, or every one tied, gives
# an undefined statistic.
friedman_numbers <- function(values) {
  n <- nrow(values)
  k <- ncol(values)
  if (n == 0 || k < 2) return(list(n = n, chi2 = NA_real_, p = NA_real_))
  if (n >= 2) {
    test <- suppressWarnings(friedman.test(values))
    return(list(n = n, chi2 = unname(test$statistic), p = test$p.value))
  }
  ranks <- rank(values[1, ])
  ties <- sum(table(values[1, ])^3 - table(values[1, ]))
  correction <- 1 - ties / (n * k * (k^2 - 1))
  if (correction <= 1e-12) return(list(n = n, chi2 = NA_real_, p = NA_real_))
  chi2 <- (12 / (n * k * (k + 1)) * sum(ranks^2) - 3 * n * (k + 1)) / correction
  list(n = n, chi2 = chi2, p = pchisq(chi2, k - 1, lower.tail = FALSE))
}

# Under the null hypothesis every ordering of a participant's (mid-)ranks is equally
# likely. The distribution of the rank sums is convolved participant by participant
# (doubled ranks, so mid-ranks are whole numbers), exactly, when that is small enough;
# otherwise permute_resamples random permutations (seed permute_seed) estimate it.
all_orders <- function(values) {
  if (length(values) <= 1) return(matrix(values, nrow = 1))
  rows <- lapply(seq_along(values), function(i) {
    cbind(values[i], all_orders(values[-i]))
  })
  do.call(rbind, rows)
}
# The Python analysis's limit (friedman_test.exact_work), so both compute the same kind of p.
exact_feasible <- function(n, k) {
  sum((seq_len(n) * 2 * k + 1)^(k - 1)) * factorial(k) <= 2e7
}
friedman_permutation_p <- function(values) {
  n <- nrow(values)
  k <- ncol(values)
  doubled <- t(apply(values, 1, function(row) round(2 * rank(row))))
  if (k == 1) doubled <- t(doubled)
  observed <- sum(colSums(doubled)^2)
  if (exact_feasible(n, k)) {
    base <- 2 * k * n + 1
    weights <- base^(seq_len(k - 1) - 1)
    keys <- 0
    probability <- 1
    for (i in seq_len(n)) {
      orders <- all_orders(doubled[i, ])[, seq_len(k - 1), drop = FALSE]
      shift <- as.vector(orders %*% weights)
      next_keys <- as.vector(outer(keys, shift, "+"))
      next_probability <- as.vector(outer(probability, rep(1 / nrow(orders), nrow(orders))))
      summed <- rowsum(next_probability, next_keys)
      keys <- as.numeric(rownames(summed))
      probability <- summed[, 1]
    }
    sums <- sapply(seq_len(k - 1), function(j) (keys %/% weights[j]) %% base)
    if (!is.matrix(sums)) sums <- matrix(sums, ncol = k - 1)
    last <- n * k * (k + 1) - rowSums(sums)
    statistic <- rowSums(sums^2) + last^2
    return(list(p = min(1, sum(probability[statistic >= observed])), method = "exact"))
  }
  set.seed(permute_seed)
  at_least <- 0
  for (b in seq_len(permute_resamples)) {
    shuffled <- t(apply(doubled, 1, sample))
    at_least <- at_least + (sum(colSums(shuffled)^2) >= observed)
  }
  list(p = (1 + at_least) / (1 + permute_resamples),
       method = sprintf("Monte Carlo, %d resamples, seed %d", permute_resamples, permute_seed))
}

# With n participants and k conditions no data can give an exact p below k!^(1 - n).
small_sample_notes <- function(measure, n, k, tests) {
  if (n == 0 || k < 2) return(invisible(NULL))
  if (n == 1) {
    cat(sprintf(paste("  note: %s: only 1 participant: Kendall's W is 1 (or undefined)",
                      "whatever the answers\n"), measure))
  }
  smallest <- factorial(k)^(1 - n)
  if (smallest * tests >= alpha) {
    cat(sprintf("  note: %s: n = %d is too few: the smallest possible exact p is %s\n", measure,
                n, format_p(smallest)))
  }
}

# ---- Effect sizes: rank-biserial r from the signed-rank test's V, median difference ----
# r = 2 V / (n (n + 1) / 2) - 1 over the non-zero differences (V as wilcox.test computes it:
# zeros dropped, |d| ranked with mid-ranks). Percentile bootstrap intervals over
# participants (R's generator, seed permute_seed: not the Python analysis's draws, so the
# bounds differ from its slightly; the estimates are the same).
rank_biserial <- function(x, y) {
  d <- x - y
  d <- d[d != 0]
  if (length(d) == 0) return(NA_real_)
  v <- sum(rank(abs(d))[d > 0])
  2 * v / (length(d) * (length(d) + 1) / 2) - 1
}
kendall_w <- function(values) {
  test <- friedman_numbers(values)
  test$chi2 / (nrow(values) * (ncol(values) - 1))
}
percentile_interval <- function(values, statistic) {
  set.seed(permute_seed)
  draws <- replicate(bootstrap_resamples, {
    statistic(values[sample.int(nrow(values), replace = TRUE), , drop = FALSE])
  })
  draws <- draws[is.finite(draws)]
  if (length(draws) < bootstrap_resamples / 2) return("no interval")
  bounds <- quantile(draws, c(0.025, 0.975), names = FALSE, type = 7)
  flag <- if (bounds[1] == bounds[2]) " (zero-width interval: not a measure of precision)" else ""
  sprintf("[%s, %s]%s", format_number(bounds[1], 3), format_number(bounds[2], 3), flag)
}

# ---- Per measure: Friedman (Bonferroni over the measures), post-hoc, effect sizes ----
cat("\nFriedman tests (exact permutation p where feasible; Kendall's W):\n")
analyse_measure <- function(measure) {
  values <- complete_values(scores, measure)
  test <- friedman_numbers(values)
  n <- test$n
  k <- length(conditions)
  if (is.na(test$chi2)) {
    cat(sprintf("%-12s chi2 undefined (n = %d; every participant's values tied or no data)\n",
                measure, n))
    small_sample_notes(measure, n, k, length(measures))
    return(invisible(NULL))
  }
  permutation <- friedman_permutation_p(values)
  p_bonferroni <- min(1, test$p * length(measures))
  permutation_bonferroni <- min(1, permutation$p * length(measures))
  cat(sprintf(paste0("%-12s chi2(%d) = %.2f, p %s, Bonferroni p %s, Kendall's W = %.3f, ",
                     "n = %d; permutation p (%s) %s, Bonferroni p %s\n"),
              measure, k - 1, test$chi2, p_is(test$p), p_is(p_bonferroni),
              test$chi2 / (n * (k - 1)), n, permutation$method, p_is(permutation$p),
              p_is(permutation_bonferroni)))
  small_sample_notes(measure, n, k, length(measures))
  pairs <- combn(seq_along(conditions), 2)
  if (permutation_bonferroni < alpha) {
    for (pair in seq_len(ncol(pairs))) {
      i <- pairs[1, pair]
      j <- pairs[2, pair]
      result <- suppressWarnings(wilcox.test(values[, i], values[, j], paired = TRUE))
      cat(sprintf("  post-hoc %s %s vs %s: V = %.1f, p %s, Bonferroni p %s\n", measure,
                  conditions[i], conditions[j], unname(result$statistic), p_is(result$p.value),
                  p_is(min(1, result$p.value * ncol(pairs)))))
    }
  }
  if (n < 2) {
    for (pair in seq_len(ncol(pairs))) {
      cat(sprintf(paste("  effect %s %s - %s: rank-biserial r = undefined, median difference",
                        "= undefined (needs at least 2 participants)\n"), measure,
                  conditions[pairs[1, pair]], conditions[pairs[2, pair]]))
    }
  } else {
    cat(sprintf("  effect %s: Kendall's W = %.3f %s\n", measure, test$chi2 / (n * (k - 1)),
                percentile_interval(values, kendall_w)))
    for (pair in seq_len(ncol(pairs))) {
      i <- pairs[1, pair]
      j <- pairs[2, pair]
      r <- rank_biserial(values[, i], values[, j])
      r_of <- function(v) rank_biserial(v[, 1], v[, 2])
      r_text <- if (is.na(r)) "undefined (all differences zero)" else
        sprintf("%.3f %s", r, percentile_interval(values[, c(i, j)], r_of))
      cat(sprintf("  effect %s %s - %s: rank-biserial r = %s, median difference = %.3f %s\n",
                  measure, conditions[i], conditions[j], r_text,
                  median(values[, i] - values[, j]),
                  percentile_interval(values[, c(i, j)], function(v) median(v[, 1] - v[, 2]))))
    }
  }
}
for (measure in measures) guarded(paste(measure, "tests"), analyse_measure(measure))

# ---- Cronbach's alpha: all ratings (bootstrap over participants), and per condition ----
alpha_of <- function(cases) {
  if (nrow(cases) < 2 || ncol(cases) < 2) return(NA_real_)
  total <- var(rowSums(cases))
  if (!is.finite(total) || total <= 1e-9 * max(sum(apply(cases, 2, var)), 1)) return(NA_real_)
  ncol(cases) / (ncol(cases) - 1) * (1 - sum(apply(cases, 2, var)) / total)
}
feldt <- function(a, n, k) {
  c(1 - (1 - a) * qf(0.975, n - 1, (n - 1) * (k - 1)),
    1 - (1 - a) * qf(0.025, n - 1, (n - 1) * (k - 1)))
}
cat("\nInternal consistency (Cronbach's alpha):\n")
rated <- merge(questionnaire[!is.na(questionnaire$scored_value), ],
               interactions[, c("participant", "session", "position", "condition")],
               by = c("participant", "session", "position"), suffixes = c(".run", ""))
alpha_of_scale <- function(measure) {
  items <- scale_items[[measure]]
  data <- rated[rated$questionnaire == measure & rated$item %in% items, ]
  keys <- unique(data[, c("participant", "session", "position", "condition")])
  cases <- matrix(NA_real_, nrow = nrow(keys), ncol = length(items))
  row_of <- match(paste(data$participant, data$session, data$position),
                  paste(keys$participant, keys$session, keys$position))
  cases[cbind(row_of, match(data$item, items))] <- data$scored_value
  complete <- stats::complete.cases(cases)
  cases <- cases[complete, , drop = FALSE]
  keys <- keys[complete, , drop = FALSE]
  a <- alpha_of(cases)
  people <- unique(keys$participant)
  interval <- "no interval"
  if (!is.na(a) && length(people) >= 2) {
    set.seed(permute_seed)
    draws <- replicate(bootstrap_resamples, {
      chosen <- sample(people, length(people), replace = TRUE)
      alpha_of(cases[unlist(lapply(chosen, function(p) which(keys$participant == p))), ,
                     drop = FALSE])
    })
    draws <- draws[is.finite(draws)]
    bounds <- quantile(draws, c(0.025, 0.975), names = FALSE)
    interval <- sprintf("95%% CI [%.2f, %.2f] (percentile bootstrap over participants)",
                        bounds[1], bounds[2])
  }
  cat(sprintf("%-12s alpha = %s, %s; n = %d ratings from %d participants, %d items\n", measure,
              format_number(a, 3), interval, nrow(cases), length(people), length(items)))
  for (condition in conditions) {
    within <- cases[keys$condition == condition, , drop = FALSE]
    a <- alpha_of(within)
    bounds <- if (is.na(a)) c(NA, NA) else feldt(a, nrow(within), ncol(within))
    cat(sprintf("  alpha %s %s: %s, 95%% CI (Feldt) [%s, %s], n = %d\n", measure, condition,
                format_number(a, 3), format_number(bounds[1], 3), format_number(bounds[2], 3),
                nrow(within)))
  }
}
for (measure in questionnaires) guarded(paste(measure, "alpha"), alpha_of_scale(measure))

# ---- The suggestion mix per condition ----
# The kind (optimal or the random fallback) depends on the participant's earlier decisions,
# so the acceptance model below leaves it out; the mix shows how different the suggestions
# were. Tested on each participant's number of random suggestions per condition.
suggestion_mix <- function() {
  mix <- merge(suggestions, interactions[, c("participant", "session", "position", "condition")],
               by = c("participant", "session", "position"), suffixes = c(".run", ""))
  cat("\nSuggestion mix per condition:\n")
  for (condition in conditions) {
    here <- mix[mix$condition == condition, ]
    total <- nrow(here)
    random <- sum(here$kind == "random")
    share <- if (total > 0) sprintf(" (%.0f%%)", 100 * random / total) else ""
    cat(sprintf("  mix %s: %d suggestions: %d optimal, %d random%s, %d moved down\n", condition,
                total, sum(here$kind == "optimal"), random, share,
                sum(here$direction %in% "down")))
  }
  randoms <- matrix(numeric(0), nrow = 0, ncol = length(conditions))
  if (nrow(mix) > 0) {
    counted <- aggregate(list(random = mix$kind == "random"),
                         by = list(participant = mix$participant, condition = mix$condition),
                         FUN = sum)
    randoms <- complete_values(counted, "random")
  }
  test <- friedman_numbers(randoms)
  if (is.na(test$chi2)) {
    cat(sprintf("  random suggestions per participant: Friedman test undefined (n = %d)\n",
                test$n))
  } else {
    permutation <- friedman_permutation_p(randoms)
    cat(sprintf(paste("  random suggestions per participant: Friedman chi2(%d) = %.2f, p %s,",
                      "permutation p (%s) %s, n = %d\n"),
                length(conditions) - 1, test$chi2, p_is(test$p), permutation$method,
                p_is(permutation$p), test$n))
  }
}
guarded("suggestion mix", suggestion_mix())
"""
