// Voxelization of a set of triangles.
//
// Shell: every cell whose (slightly enlarged, closed) box meets a triangle, by the separating-axis test
// of Akenine-Möller, so a closed surface leaves no face-connected gap. Fill: the cells that a flood from
// the empty border layer cannot reach through face neighbours are enclosed; for an open surface that
// leaves only the shell, for a closed one its interior too. The grid is centred on the triangles'
// bounding box so that axis-aligned faces fall mid-cell rather than on cell boundaries. Both passes poll for
// interrupts (od_CheckInterrupt: every OD_VOXEL_POLL + 1 triangles or flooded cells).
#include "mesh_graph.h"

#include "core.h"
#include "interrupt.h"
#include "math3.h"

#include <math.h>
#include <string.h>

#define OD_VOXEL_POLL 4095 // triangles or flooded cells between interrupt checks, less one (a power of two less one)

enum
{
	OD_CELL_EMPTY = 0,
	OD_CELL_SHELL = 1,
	OD_CELL_OUTSIDE = 2,
};

static void od_Bounds(const double* vertices, const int* triangles, const int* list, int count, double lo[3],
					  double hi[3])
{
	for (int a = 0; a < 3; ++a)
	{
		lo[a] = INFINITY;
		hi[a] = -INFINITY;
	}
	for (int i = 0; i < count; ++i)
	{
		for (int k = 0; k < 3; ++k)
		{
			const double* p = vertices + 3 * triangles[3 * list[i] + k];
			for (int a = 0; a < 3; ++a)
			{
				lo[a] = fmin(lo[a], p[a]);
				hi[a] = fmax(hi[a], p[a]);
			}
		}
	}
}

// The grid around the bounding box; returns its cell count (as a double: it may not fit an int).
static double od_Frame(const double lo[3], const double hi[3], double h, double origin[3], int dims[3])
{
	double cells = 1.0;
	for (int a = 0; a < 3; ++a)
	{
		double d = floor((hi[a] - lo[a]) / h) + 3.0;
		dims[a] = d < 1e9 ? (int)d : 1000000000;
		origin[a] = 0.5 * (lo[a] + hi[a]) - 0.5 * d * h;
		cells *= d;
	}
	return cells;
}

double od_Voxels_CellCount(const double* vertices, const int* triangles, const int* list, int count, double h)
{
	double lo[3], hi[3], origin[3];
	int dims[3];
	od_Bounds(vertices, triangles, list, count, lo, hi);
	return od_Frame(lo, hi, h, origin, dims);
}

// Separating-axis test of a triangle (corners relative to the cube's centre) against a cube of half size r:
// the three box normals, the triangle's normal and the nine edge-by-axis cross products.
static bool od_TriangleTouchesCube(const od_Vec3 v[3], double r)
{
	od_Vec3 e[3] = { od_Sub(v[1], v[0]), od_Sub(v[2], v[1]), od_Sub(v[0], v[2]) };
	od_Vec3 unit[3] = { od_V3(1, 0, 0), od_V3(0, 1, 0), od_V3(0, 0, 1) };
	od_Vec3 axes[13];
	int count = 0;
	for (int a = 0; a < 3; ++a)
	{
		axes[count++] = unit[a];
		for (int k = 0; k < 3; ++k)
		{
			axes[count++] = od_Cross(unit[a], e[k]);
		}
	}
	axes[count++] = od_Cross(e[0], e[1]);
	for (int i = 0; i < count; ++i)
	{
		od_Vec3 ax = axes[i];
		double p0 = od_Dot(ax, v[0]), p1 = od_Dot(ax, v[1]), p2 = od_Dot(ax, v[2]);
		double reach = r * (fabs(ax.x) + fabs(ax.y) + fabs(ax.z));
		if (fmin(p0, fmin(p1, p2)) > reach || fmax(p0, fmax(p1, p2)) < -reach)
		{
			return false;
		}
	}
	return true;
}

static void od_MarkShell(const od_Voxels* g, const double* vertices, const int* tri, unsigned char* state)
{
	od_Vec3 corner[3];
	int lo[3], hi[3];
	for (int a = 0; a < 3; ++a)
	{
		double mn = INFINITY, mx = -INFINITY;
		for (int k = 0; k < 3; ++k)
		{
			double x = (vertices[3 * tri[k] + a] - g->origin[a]) / g->h;
			mn = fmin(mn, x);
			mx = fmax(mx, x);
		}
		lo[a] = (int)fmax(1.0, floor(mn - 1e-6));
		hi[a] = (int)fmin(g->dims[a] - 2.0, floor(mx + 1e-6));
	}
	double r = 0.5 * g->h * (1.0 + 1e-6);
	for (int z = lo[2]; z <= hi[2]; ++z)
	{
		for (int y = lo[1]; y <= hi[1]; ++y)
		{
			for (int x = lo[0]; x <= hi[0]; ++x)
			{
				size_t c = ((size_t)z * g->dims[1] + y) * g->dims[0] + x;
				if (state[c] == OD_CELL_SHELL)
				{
					continue;
				}
				od_Vec3 center = od_V3(g->origin[0] + (x + 0.5) * g->h, g->origin[1] + (y + 0.5) * g->h,
									   g->origin[2] + (z + 0.5) * g->h);
				for (int k = 0; k < 3; ++k)
				{
					corner[k] = od_Sub(od_V3Load(vertices + 3 * tri[k]), center);
				}
				if (od_TriangleTouchesCube(corner, r))
				{
					state[c] = OD_CELL_SHELL;
				}
			}
		}
	}
}

// Marks OD_CELL_OUTSIDE every empty cell reachable from cell 0 (in the empty border layer).
static od_Status od_FloodOutside(const od_Voxels* g, unsigned char* state, int* queue)
{
	int nx = g->dims[0], nxy = g->dims[0] * g->dims[1];
	int head = 0, tail = 0;
	queue[tail++] = 0;
	state[0] = OD_CELL_OUTSIDE;
	while (head < tail)
	{
		od_Status status = (head & OD_VOXEL_POLL) == 0 ? od_CheckInterrupt() : OD_OK;
		if (status != OD_OK)
		{
			return status;
		}
		int c = queue[head++];
		int x = c % nx, y = (c / nx) % g->dims[1], z = c / nxy;
		int next[6] = { x > 0 ? c - 1 : -1,
						x + 1 < nx ? c + 1 : -1,
						y > 0 ? c - nx : -1,
						y + 1 < g->dims[1] ? c + nx : -1,
						z > 0 ? c - nxy : -1,
						z + 1 < g->dims[2] ? c + nxy : -1 };
		for (int k = 0; k < 6; ++k)
		{
			if (next[k] >= 0 && state[next[k]] == OD_CELL_EMPTY)
			{
				state[next[k]] = OD_CELL_OUTSIDE;
				queue[tail++] = next[k];
			}
		}
	}
	return OD_OK;
}

// Filled: everything but the outside; not filled: the shell only.
static bool od_IsSolid(unsigned char state, bool fill)
{
	return fill ? state != OD_CELL_OUTSIDE : state == OD_CELL_SHELL;
}

od_Status od_Voxelize(const double* vertices, const int* triangles, const int* list, int count, double h, bool fill,
					  od_Voxels* g)
{
	memset(g, 0, sizeof *g);
	if (!(h > 0.0) || !isfinite(h)) // a mesh with no extent (one point) asks for an infinite cell
	{
		return od_Fail(OD_ERROR_ARGUMENT, "cannot voxelize with a cell size of %g: the mesh has no extent", h);
	}
	double lo[3], hi[3];
	od_Bounds(vertices, triangles, list, count, lo, hi);
	double cellCount = od_Frame(lo, hi, h, g->origin, g->dims);
	if (cellCount > OD_VOXEL_CELL_LIMIT)
	{
		return od_Fail(OD_ERROR_INTERNAL, "a voxel grid of %.0f cells is over the limit", cellCount);
	}
	g->h = h;
	int cells = (int)cellCount;
	unsigned char* state = od_AllocZero((size_t)cells, 1);
	int* queue = fill ? od_Alloc(sizeof(int) * (size_t)cells) : NULL;
	if (!state || (fill && !queue))
	{
		od_Free(state);
		od_Free(queue);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for a voxel grid of %d cells", cells);
	}
	od_Status status = OD_OK;
	for (int i = 0; i < count && status == OD_OK; ++i)
	{
		status = (i & OD_VOXEL_POLL) == 0 ? od_CheckInterrupt() : OD_OK;
		if (status == OD_OK)
		{
			od_MarkShell(g, vertices, triangles + 3 * list[i], state);
		}
	}
	status = status == OD_OK && fill ? od_FloodOutside(g, state, queue) : status;
	od_Free(queue);
	if (status != OD_OK)
	{
		od_Free(state);
		return status;
	}
	for (int c = 0; c < cells; ++c)
	{
		g->count += od_IsSolid(state[c], fill);
	}
	g->cells = od_Alloc(sizeof(int) * (size_t)(g->count ? g->count : 1));
	g->shell = od_Alloc(sizeof(bool) * (size_t)(g->count ? g->count : 1));
	if (!g->cells || !g->shell)
	{
		od_Free(state);
		od_Voxels_Destroy(g);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for %d voxels", g->count);
	}
	for (int c = 0, k = 0; c < cells; ++c)
	{
		if (od_IsSolid(state[c], fill))
		{
			g->shell[k] = state[c] == OD_CELL_SHELL;
			g->cells[k++] = c;
		}
	}
	od_Free(state);
	return OD_OK;
}

void od_Voxels_Destroy(od_Voxels* g)
{
	od_Free(g->cells);
	od_Free(g->shell);
	g->cells = NULL;
	g->shell = NULL;
	g->count = 0;
}

void od_Voxels_Center(const od_Voxels* g, int i, double out[3])
{
	int c = g->cells[i];
	int x = c % g->dims[0], y = (c / g->dims[0]) % g->dims[1], z = c / (g->dims[0] * g->dims[1]);
	out[0] = g->origin[0] + (x + 0.5) * g->h;
	out[1] = g->origin[1] + (y + 0.5) * g->h;
	out[2] = g->origin[2] + (z + 0.5) * g->h;
}
