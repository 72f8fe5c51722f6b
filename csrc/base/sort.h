// A sort of long arrays that polls for interrupts (sort.c).
#pragma once

#include "opdeform/base.h"

#include <stddef.h>

// Sorts count items of size bytes in ascending order of compare, polling od_CheckInterrupt every
// OD_SORT_RUN items. Stable; the result is qsort's wherever compare returns 0 only for identical items (a
// total order, or ties only between equal bytes). OD_ERROR_MEMORY (a buffer of count items) or
// OD_ERROR_INTERRUPTED leave the items in some order.
od_Status od_Sort(void* items, size_t count, size_t size, int (*compare)(const void*, const void*));
