"""The pieces of examples/benchmarks/bench_performance.py and the shared helpers of the other
benchmark scripts: ``machine`` (CPU model, versions, load, medians), ``scenes`` (host
scenes and the shipped parade), ``suites`` (the measurements), ``report`` (markdown and plots).
"""
