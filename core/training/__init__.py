"""The predictor's training stages, above evaluation (a candidate is selected by closed-loop episodes):
data collection and mixing (``collect``), the training config and result (``config``), the closed-loop proxy
(``proxy``), training itself (``train``, torch) and the ETH/UCY predictor benchmark (``predict_eval``)."""
