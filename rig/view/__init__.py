"""The view: a read-only web page served from the rig PC (``rig view``, ``rig run --view``).

- ``meta``: what a run's columns are (per axis, with units), from its files;
- ``scope``: the live scope's state, fed off the control thread and read by the server;
- ``feed``: the scope fed from the recorder's ring of rows (``rig run --view``), or from a run
  directory's ``samples.csv`` as it grows (``rig view RUN_DIR``);
- ``store``: the run directories, studies and identifications under a folder, read from disk;
- ``app``: the web application (Starlette), every route a GET, with its guards;
- ``server``: the address, the token, and uvicorn in a thread or in the foreground.

Starlette and uvicorn are the ``view`` extra; only ``rig view`` and ``rig run --view`` import
them. The page and uPlot (``static/third_party/uplot``, MIT) ship in the package: nothing is
fetched at run time.
"""
