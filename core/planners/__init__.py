"""Robot controllers behind one protocol: goal-seeking, baselines and the predictive planner."""
