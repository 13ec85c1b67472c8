"""The paper's reproduction, apart from the library: what regenerates the article's tables and figures.

* :mod:`.specs` — the paper's datasets (:data:`PAPER_SPECS`) and their files;
* :mod:`.published` — the paper's published numbers, in one place;
* :mod:`.fitting` — train the paper's subspace models on a dataset and score them;
* :mod:`.tables` — the experiments behind Tables 1–3;
* :mod:`.runtime` — the run-time comparison (classical against the network);
* :mod:`.report` — ``results/REPORT.md``, every reproduced number beside the paper's;
* :mod:`.parts` — one module per part of the paper (per notebook and DVC stage): its ``run``,
  ``save``, ``figures`` and ``Metrics`` schema, registered with its place in the run order and the
  parts it reads; the notebooks call them;
* :mod:`.pipeline` — the papermill runner of the notebooks (``wsmap paper run``), in the parts' order;
* :mod:`.full` — the paper's scale, part by part and resumable (``wsmap paper full``).
"""
