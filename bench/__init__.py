"""Benchmarks (not part of the test suite): ``python -m bench.worker_bench [--quick]``."""
