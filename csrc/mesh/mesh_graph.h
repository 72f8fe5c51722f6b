// Internal stages of building a graph from a mesh: the mesh's connected pieces (mesh_topology.c) and the
// voxelization of a set of triangles (voxelize.c), used by mesh_graph.c.
#pragma once

#include "opdeform/mesh.h"

// Cells of a voxel grid never exceed this (bytes and ints per cell while building).
#define OD_VOXEL_CELL_LIMIT (1 << 23)

// Connected pieces of a mesh. Vertices closer than a tiny tolerance (1e-8 of the bounding box) are welded
// first, so duplicated vertices (split normals, UV seams) do not split a piece.
typedef struct od_MeshPieces
{
	int count;
	int* triangleStart;   // count+1
	int* triangles;       // triangle indices grouped by piece (ascending in each), pieces by first triangle
	double* area;         // count
	double* volume;       // count, |enclosed volume| (meaningful for closed pieces)
	bool* closed;         // count: every edge of its non-degenerate triangles is shared by exactly two
	int* pieceOfVertex;   // vertexCount: the piece of each vertex, -1 for a vertex of no triangle
	int distinctVertices; // vertices used by triangles, after welding
	double span;          // the diagonal of the triangles' bounding box; welded: closer than OD_WELD_FRACTION of it
} od_MeshPieces;

#define OD_WELD_FRACTION 1e-8
// A mesh's span (m): its particles' radii must lie in [OD_MIN_RADIUS, OD_MAX_RADIUS] (graph.h), and its
// volumes and moments be finite (spans 1e300 and 1e150 ended in an overflow or a NaN cell size, issue 28).
#define OD_MIN_SPAN 1e-9
#define OD_MAX_SPAN 1e12

od_Status od_MeshPieces_Find(const od_MeshGraphDef* def, od_MeshPieces* pieces);
// qsort order of int pairs (the first two ints of each item): by the first, then the second.
int od_CompareIntPairs(const void* a, const void* b);
void od_MeshPieces_Destroy(od_MeshPieces* pieces);

// The solid cells of a voxelization: cells touched by a triangle, plus (fill) every cell that the
// triangles enclose. The grid has one empty layer of cells around the triangles' bounding box.
typedef struct od_Voxels
{
	double origin[3]; // corner of cell (0, 0, 0)
	double h;         // cell size
	int dims[3];
	int count;
	int* cells;       // count linear cell indices ((z * dims[1] + y) * dims[0] + x), ascending
	bool* shell;      // count: whether a triangle touches the voxel
} od_Voxels;

// The number of cells of the grid that od_Voxelize would use (to keep it below OD_VOXEL_CELL_LIMIT).
double od_Voxels_CellCount(const double* vertices, const int* triangles, const int* list, int count, double h);
// Voxelizes the triangles list[0..count) at cell size h (polls for interrupts: OD_ERROR_INTERRUPTED).
od_Status od_Voxelize(const double* vertices, const int* triangles, const int* list, int count, double h, bool fill,
					  od_Voxels* voxels);
void od_Voxels_Destroy(od_Voxels* voxels);
// The centre of voxel i.
void od_Voxels_Center(const od_Voxels* voxels, int i, double out[3]);
