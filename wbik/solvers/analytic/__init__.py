"""Method ``analytic``: closed-form IK, every branch, vectorised over batches of targets; layered as IK-Geo
(subproblems -> families -> a robot package's bindings, see docs/architecture.md)."""
