// A growable array of bytes, for outputs of unknown size (mesh files, edge lists, queues), and the resize
// of an array whose size is known.
#pragma once

#include "core.h"

#include <string.h>

typedef struct od_Buffer
{
	char* data;
	size_t size, capacity;
} od_Buffer;

// Makes room for `count` more bytes (the capacity doubles as needed).
static inline od_Status od_BufferReserve(od_Buffer* b, size_t count)
{
	if (b->size + count <= b->capacity)
	{
		return OD_OK;
	}
	size_t capacity = b->capacity ? b->capacity : 4096;
	while (capacity < b->size + count)
	{
		capacity *= 2;
	}
	char* data = od_Realloc(b->data, capacity);
	if (!data)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory growing a buffer to %zu bytes", capacity);
	}
	b->data = data;
	b->capacity = capacity;
	return OD_OK;
}

static inline od_Status od_BufferAppend(od_Buffer* b, const void* bytes, size_t count)
{
	od_Status status = od_BufferReserve(b, count);
	if (status == OD_OK)
	{
		memcpy(b->data + b->size, bytes, count);
		b->size += count;
	}
	return status;
}

// Resizes *p to `bytes` (at least 1); on failure *p is kept and the message names `what`.
static inline od_Status od_Resize(void** p, size_t bytes, const char* what)
{
	void* q = od_Realloc(*p, bytes ? bytes : 1);
	if (!q)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the %s", what);
	}
	*p = q;
	return OD_OK;
}

// Makes room for `needed` items of `item` bytes in *p (the capacity doubles from 8); on failure *p is kept and
// the message names `what`.
static inline od_Status od_Grow(void** p, int* capacity, int needed, size_t item, const char* what)
{
	if (needed <= *capacity)
	{
		return OD_OK;
	}
	int cap = *capacity ? *capacity : 8;
	while (cap < needed)
	{
		cap *= 2;
	}
	void* q = od_Realloc(*p, (size_t)cap * item);
	if (!q)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory growing the %s", what);
	}
	*p = q;
	*capacity = cap;
	return OD_OK;
}
