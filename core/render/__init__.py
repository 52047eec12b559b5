"""Pictures (matplotlib, Agg backend, Figure objects only): map previews and episode traces.

matplotlib is imported only inside this package, so the rest of ``core`` stays plot-free.
"""
