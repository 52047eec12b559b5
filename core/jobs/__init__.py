"""The job table at the top of core: every job kind (``kinds``), its result model and verdict (``results``),
budgets, the one-episode ``simulate`` stage, training as a Ray task, and the pipeline of stages (``pipeline``)."""
