"""Tidy exports of a study's data (CSV always; Parquet, Excel, JSON when asked)."""
