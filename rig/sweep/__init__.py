"""``rig sweep``: a robustness study, many runs of one rig over varied parameters, on Dask.

- ``spec``: the study's TOML file (its base, the parameters to vary and how, the metrics), checked
  once at load;
- ``load``: ``load_spec``, the file read and every value checked against the base;
- ``points``: the points of a grid, of random or Latin hypercube samples, with repeats over seeds;
- ``point``: one point on a worker: a ``rig run --emulate`` of the base configuration with the
  point's values (through ``rig.host.session``, the public path) or a paper's pure simulation
  (``scenarios``), to one row of figures;
- ``table``: the rows, written to ``results.parquet`` as they come, beside ``sweep.json``;
- ``engine``: Dask distributed (a local cluster, or a lab's scheduler by address) and the loop
  that streams the rows in; ``plot``: each metric over one or two varied parameters.

Only the sweep's commands import Dask and pyarrow (the ``sweep`` extra); a ``rig run`` never does.
"""

__all__: list[str] = []
