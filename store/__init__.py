"""The store: everything Foresight keeps, and the only package that talks to the database.

``settings`` (where things are), ``models`` (ORM tables) and ``session`` (engines, migrations), ``queue`` (the
job-queue SQL), ``registry`` (bundles and models: register, promote, resolve, the default-model rule),
``records`` (result rows of finished jobs) and ``folders`` (the artifact root: job folders, safe paths, hashes).
``api/`` and ``worker/`` both import it, never each other; it imports only ``core``.
"""
