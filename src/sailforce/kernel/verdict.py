"""Where the compiled kernel hands a pose's singular verdict to numpy (shared by both back-ends, without numba)."""

from __future__ import annotations

#: |sin(delta)| this close to the singular threshold gets its verdict from libm's sin and cos (numpy's):
#: the compiled polynomial's sin(delta) = s1 c2 - c1 s2 is within ~4 ulp (1e-15) of libm's; the band is 100 times that.
VERDICT_BAND = 1e-13
#: The compiled kernel's ``singular`` flag for a pose inside :data:`VERDICT_BAND` (0 regular, 1 singular).
NEAR = 2
