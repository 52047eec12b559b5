"""What every stage runs on, below all of them: the context a runner hands a stage (``context``), the typed
references its config uses (``refs``), and where its episodes ran (``execution``, ``cluster``)."""
