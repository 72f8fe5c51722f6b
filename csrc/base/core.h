// Internal helpers shared by the files of the C core: error messages and allocation.
#pragma once

#include "opdeform/base.h"

#include <stddef.h>

#if defined(__GNUC__)
#define OD_PRINTF(a, b) __attribute__((format(printf, a, b)))
#else
#define OD_PRINTF(a, b)
#endif

// Records a message for od_GetErrorMessage() and returns status, so callers can `return od_Fail(...)`.
od_Status od_Fail(od_Status status, const char* format, ...) OD_PRINTF(2, 3);

// Allocation that counts bytes (for leak and "no allocation per step" checks); NULL on failure.
void* od_Alloc(size_t size);
void* od_AllocZero(size_t count, size_t size);
void* od_Realloc(void* p, size_t size);
void od_Free(void* p);
