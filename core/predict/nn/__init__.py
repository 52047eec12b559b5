"""The learned trajectory predictor (torch lives only in this subpackage): model, checkpoints, training."""
