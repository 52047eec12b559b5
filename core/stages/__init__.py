"""Pipeline stages: each is ``run_<stage>(config, ctx) -> result`` over a validated config."""
