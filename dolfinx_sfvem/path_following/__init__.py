"""Following the load path: Newton through PETSc SNES, load stepping, arc-length, continuation and adaptivity."""
