"""Jobs: what the command line runs, as objects a Python user can build, check, run and save.

* `MapJob` (`.map`) — one workspace map of one arm and its files (`wsmap map`);
* `PlacementJob` (`.placement`) — where to put an arm's base for a set of target poses (`wsmap place`).

A job is a frozen record of its inputs with three steps: `check()` (every input checked before
any work or file; a plan), `run()` (the computation; a result with its settings and provenance)
and `save(result)` (the files, each through a temporary file put in place on success). The command
line only parses its options into a job, runs it and prints; the same job built in Python writes
the same bytes. The arm of a job is a `wsmap.robots.sources.ArmSource`, its collision geometry a
`wsmap.collision.sources.CollisionSource`.
"""

from ..collision.sources import CollisionSource
from ..robots.sources import ArmSource
from .map import MapJob, MapOutputs, MapPlan, MapResult
from .placement import PlacementJob, PlacementPlan, PlacementResult

__all__ = ["ArmSource", "CollisionSource", "MapJob", "MapOutputs", "MapPlan", "MapResult", "PlacementJob",
           "PlacementPlan", "PlacementResult"]
