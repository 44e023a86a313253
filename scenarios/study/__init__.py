"""``calibench montecarlo``: accuracy studies of a scenario, locally or on a Dask cluster.

``montecarlo`` (:func:`run_study`) drives a study; ``trials`` is what a worker runs, ``executor``
where it runs, ``journal`` the folder's resumable record, ``summary`` the statistics and their
tables, ``outputs`` the files written from them.
"""
