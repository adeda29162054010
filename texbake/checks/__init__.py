"""What checks the bake, kept out of the stages' way: the numerical stability cases
(``stability``, ``texbake stability``), the sweep of error against run time against a
converged reference (``sweep``, ``texbake report``; its plot needs the ``report`` extra,
matplotlib), and plain float64 reference implementations of the lecture's noise
(``reference``) that the tests and the stability cases compare the kernels with."""
