"""A sweep's frames and trust checks: the summary and trajectories of its outcomes
(:mod:`optimize.sweep.outputs`), the mesh and simulation checks (:mod:`optimize.sweep.trust`).
Its plan and executors are the solve service's (:mod:`optimize.service.plan`,
:mod:`optimize.service.executors`)."""
