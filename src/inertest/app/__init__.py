"""The application wing: a run as one transaction, batches of runs, and their executors.

:mod:`~inertest.app.run` fits, reports and stores one test (``inertest fit``) so that nothing
is stored or written unless every step succeeds; :mod:`~inertest.app.batch` does it for the
runs of a manifest (``inertest batch``) on :mod:`~inertest.app.executors` (a process pool or a
Dask cluster).
"""
