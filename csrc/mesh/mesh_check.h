// Validation shared by everything that takes a triangle mesh (graph building, skinning, writing files):
// counts and pointers, finite vertices (when asked) and triangle indices in range, with messages that
// name the offending entry.
#pragma once

#include "core.h"
#include "math3.h"

#include <stdbool.h>

static inline od_Status od_CheckMesh(int vertexCount, const double* vertices, int triangleCount, const int* triangles,
									 bool finite)
{
	if (vertexCount < 0 || triangleCount < 0 || (vertexCount && !vertices) || (triangleCount && !triangles))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "a mesh needs its vertices and triangles (%d vertices, %d triangles)",
					   vertexCount, triangleCount);
	}
	for (int v = 0; v < vertexCount && finite; ++v)
	{
		if (!od_IsFinite3(vertices + 3 * v))
		{
			return od_Fail(OD_ERROR_ARGUMENT, "vertices[%d] is not finite", v);
		}
	}
	for (int t = 0; t < 3 * triangleCount; ++t)
	{
		if (triangles[t] < 0 || triangles[t] >= vertexCount)
		{
			return od_Fail(OD_ERROR_ARGUMENT, "triangles[%d] refers to vertex %d, but there are %d vertices", t / 3,
						   triangles[t], vertexCount);
		}
	}
	return OD_OK;
}
