// A monotonic clock for the time counters of the solvers (platform.c: each system its own).
#pragma once

// Seconds since an arbitrary start, monotonic.
double od_Clock(void);
