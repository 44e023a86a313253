"""``calibench montecarlo``: accuracy studies of a scenario, locally or on a Dask cluster."""
