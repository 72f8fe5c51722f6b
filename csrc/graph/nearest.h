// Exact k-nearest-point queries over a fixed point set (the particle centres): brute force for a few
// queries, a uniform grid for many. Both order by (distance, index), so they return the same points and
// the same distances, bit for bit.
#pragma once

#include "opdeform/base.h"

typedef struct od_NearestGrid
{
	const double* points; // borrowed, count*3
	int count;
	double origin[3];
	double cell;
	int dims[3];
	int* cellStart; // cells+1
	int* items;     // point indices grouped by cell, ascending within a cell
} od_NearestGrid;

// Keeps the k best (distance, index) pairs sorted ascending in dist/idx; returns the new count.
int od_InsertNearest(double* dist, int* idx, int count, int k, double d, int i);

// The k nearest of count points to p, by brute force; returns how many were found (at most k). With a
// label array, only the points i with label[i] == want take part.
int od_NearestBrute(const double* points, int count, const int* label, int want, const double p[3], int k,
					double* dist, int* idx);

od_Status od_NearestGrid_Create(od_NearestGrid* grid, const double* points, int count);
void od_NearestGrid_Destroy(od_NearestGrid* grid);
// The same answer as od_NearestBrute, visiting only the cells that can hold one of the k nearest. With a
// label array, k must not exceed the number of points labelled `want` (or the whole grid is searched).
int od_NearestGrid_Query(const od_NearestGrid* grid, const int* label, int want, const double p[3], int k,
						 double* dist, int* idx);
