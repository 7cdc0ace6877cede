"""The paper's analysis from the database: Table I, Friedman tests, plots, error scores."""
