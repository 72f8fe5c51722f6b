// Per-thread error messages and counted allocation.
#include "core.h"

#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>

static _Thread_local char od_message[512];

od_Status od_Fail(od_Status status, const char* format, ...)
{
	va_list args;
	va_start(args, format);
	vsnprintf(od_message, sizeof od_message, format, args);
	va_end(args);
	return status;
}

const char* od_GetErrorMessage(void)
{
	return od_message;
}

const char* od_StatusName(od_Status status)
{
	switch (status)
	{
		case OD_OK:
			return "OD_OK";
		case OD_ERROR_ARGUMENT:
			return "OD_ERROR_ARGUMENT";
		case OD_ERROR_NOT_FOUND:
			return "OD_ERROR_NOT_FOUND";
		case OD_ERROR_MEMORY:
			return "OD_ERROR_MEMORY";
		case OD_ERROR_SINGULAR:
			return "OD_ERROR_SINGULAR";
		case OD_ERROR_NOT_FINITE:
			return "OD_ERROR_NOT_FINITE";
		case OD_ERROR_BUSY:
			return "OD_ERROR_BUSY";
		case OD_ERROR_INTERNAL:
			return "OD_ERROR_INTERNAL";
		case OD_ERROR_INTERRUPTED:
			return "OD_ERROR_INTERRUPTED";
	}
	return "OD_UNKNOWN";
}

static _Atomic long long od_allocations;

void* od_Alloc(size_t size)
{
	od_allocations++;
	return malloc(size ? size : 1);
}

void* od_AllocZero(size_t count, size_t size)
{
	od_allocations++;
	return calloc(count ? count : 1, size ? size : 1);
}

void* od_Realloc(void* p, size_t size)
{
	od_allocations++;
	return realloc(p, size ? size : 1);
}

void od_Free(void* p)
{
	free(p);
}

long long od_GetAllocationCount(void)
{
	return od_allocations;
}
