// A monotonic clock for the time counters of the solvers (clock.c).
#pragma once

// Seconds since an arbitrary start, monotonic.
double od_Clock(void);
