// A sort of long arrays that polls for interrupts.
//
// Design: runs of OD_SORT_RUN items are sorted by qsort (a few ms each at most), then merged pairwise into a
// buffer of the same size and back, bottom up, polling od_CheckInterrupt between runs and every OD_SORT_RUN
// items merged, so a Ctrl-C waits one run at most (qsort itself cannot be stopped: a million 32-byte items
// took 0.2 s). The merge takes the left item on ties, so the sort is stable; with compare a total order
// (equal only for identical items) the output is the one qsort gives. One buffer per call, none per item.
#include "sort.h"

#include "core.h"
#include "interrupt.h"

#include <stdbool.h>
#include <stdlib.h>
#include <string.h>

#define OD_SORT_RUN ((size_t)4096)

typedef int od_Compare(const void*, const void*);

// Merges the sorted [from, middle) and [middle, to) of src into dst at from (indices in items).
static od_Status od_Merge(const char* src, char* dst, size_t from, size_t middle, size_t to, size_t size,
						  od_Compare* compare)
{
	size_t i = from, j = middle;
	for (size_t k = from; k < to; ++k)
	{
		if ((k & (OD_SORT_RUN - 1)) == 0)
		{
			od_Status status = od_CheckInterrupt();
			if (status != OD_OK)
			{
				return status;
			}
		}
		bool left = j >= to || (i < middle && compare(src + i * size, src + j * size) <= 0);
		memcpy(dst + k * size, src + (left ? i++ : j++) * size, size);
	}
	return OD_OK;
}

od_Status od_Sort(void* items, size_t count, size_t size, od_Compare* compare)
{
	char* base = items;
	for (size_t from = 0; from < count; from += OD_SORT_RUN)
	{
		od_Status status = od_CheckInterrupt();
		if (status != OD_OK)
		{
			return status;
		}
		qsort(base + from * size, count - from < OD_SORT_RUN ? count - from : OD_SORT_RUN, size, compare);
	}
	if (count <= OD_SORT_RUN)
	{
		return OD_OK;
	}
	char* buffer = od_Alloc(count * size);
	if (!buffer)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory sorting %zu items of %zu bytes", count, size);
	}
	char *src = base, *dst = buffer;
	od_Status status = OD_OK;
	for (size_t width = OD_SORT_RUN; width < count && status == OD_OK; width *= 2)
	{
		for (size_t from = 0; from < count && status == OD_OK; from += 2 * width)
		{
			size_t middle = count - from < width ? count : from + width;
			size_t to = count - from < 2 * width ? count : from + 2 * width;
			status = od_Merge(src, dst, from, middle, to, size, compare);
		}
		char* swap = src;
		src = dst;
		dst = swap;
	}
	if (status == OD_OK && src != base)
	{
		memcpy(base, src, count * size);
	}
	od_Free(buffer);
	return status;
}
