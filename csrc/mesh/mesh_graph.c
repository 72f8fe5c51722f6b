// Building an oriented-particle graph from a triangle mesh (METHOD.md, "Building a graph from a mesh").
//
// 1. Pieces: connected components over welded vertices (mesh_topology.c). Each piece is a group of its
//    own or, with joinPieces, pieces whose bounding boxes overlap share a group (so that overlapping parts
//    become one solid); separate groups of joined pieces are linked at the end by edges between their
//    nearest particles.
// 2. Voxels: every group is voxelized (voxelize.c) at one common cell size h, filled (closed pieces in
//    auto and chain modes, every piece in volume mode) or as a shell (open pieces, surface mode). h is
//    chosen so that there are about voxelsPerParticle voxels per particle: first from the area and the
//    enclosed volume, then corrected by counting.
// 3. Particles are shared among groups in proportion to their voxels (one each first, largest first, while
//    they last), never more than a group has voxels. A small group (under OD_SMALL_PIECE_RATIO of the
//    largest one's voxels: an eye, a button) gets none when attached; when it has its own, at least
//    OD_SMALL_PIECE_PARTICLES when compact (those at most OD_SMALL_PIECE_SHARE of the budget together,
//    largest first; the next ones theirs beyond the budget, at most OD_SMALL_PIECE_EXTRA of it; the rest
//    attached), and when long or flat its share and, where that is under
//    OD_SHELL_PARTICLES, particles added beyond the budget up to that.
// 4. Cells: the voxels of a group are split into as many cells as it has particles by geodesic k-means on
//    the voxel graph (26-neighbours): seeds at the centroids of a balanced k-d split of the voxels (O(N log
//    k), where farthest-point seeding costs up to O(N k)), cells grown from them by Dijkstra, then Lloyd
//    steps that move every seed to the voxel nearest its cell's centroid. Geodesic distance keeps a cell
//    from spanning a gap (two legs side by side). Chain mode instead cuts a group into slabs along its
//    principal axis.
// 5. Particles: each cell gives one ellipsoid at its centroid along its principal axes. The covariance
//    of the union of the cell's voxel cubes is that of their centres plus h²/12 I, and a solid ellipsoid
//    of radii r has covariance diag(r²)/5, so r = sqrt(5 λ) (always > 0). Voxels that the surface crosses
//    are on average half inside, so they weigh half in a filled body (which keeps the ellipsoids from
//    growing by the voxelization's overshoot).
// 6. Edges: cells that share a voxel face; where that leaves a group in several parts, cells touching at
//    a voxel edge or corner; then (separate solids of a joined group) the nearest particle pairs between
//    parts (Borůvka), so that each group's graph is connected. Chain mode joins slab i to slab i + 1.
// 7. Mesh pieces: each particle of a small group of its own is linked to the nearest large group; the graph
//    records the group of each particle and vertex, and the group that carries each group without
//    particles (graph/piece_map.c), so that a vertex is skinned only by its own piece.
// Everything runs in one thread with ties broken by index, so the graph is the same bit for bit.
#include "mesh_graph.h"

#include "buffer.h"
#include "core.h"
#include "graph.h"
#include "interrupt.h"
#include "math3.h"
#include "mesh_check.h"
#include "nearest.h"
#include "polar.h"
#include "sort.h"
#include "union_find.h"

#include <limits.h>
#include <math.h>
#include <stdlib.h>
#include <string.h>

#define OD_LLOYD_STEPS 10
#define OD_SPREAD_POLL 4095u // voxels taken from Dijkstra's queue between interrupt checks, less one
#define OD_VOXEL_PASSES 8
// A group's grid holds at most this many cells per voxel wanted (and at least OD_VOXEL_CELL_FLOOR): a sliver
// or a spike (a cube with one corner pulled 1e5 m out) filled 1/10^9 of its box and voxelized the full
// OD_VOXEL_CELL_LIMIT in each pass (0.4-1.7 s for 8 vertices, issue 28); an ordinary body fills a tenth or more.
#define OD_VOXEL_CELLS_PER_VOXEL 1000.0
#define OD_VOXEL_CELL_FLOOR 65536.0

od_MeshGraphDef od_DefaultMeshGraphDef(void)
{
	od_MeshGraphDef def;
	memset(&def, 0, sizeof def);
	def.particleCount = 100;
	def.mode = OD_MESH_AUTO;
	def.voxelsPerParticle = 100;
	return def;
}

static od_Status od_CheckMeshGraphDef(const od_MeshGraphDef* def)
{
	if (def->vertexCount < 1 || def->triangleCount < 1 || !def->vertices || !def->triangles)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "the mesh is empty (%d vertices, %d triangles): it needs triangles",
					   def->vertexCount, def->triangleCount);
	}
	if (def->particleCount < 1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "particles = %d must be >= 1", def->particleCount);
	}
	if (def->mode < OD_MESH_AUTO || def->mode > OD_MESH_CHAIN)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "mode = %d is not a mesh graph mode", (int)def->mode);
	}
	if (def->voxelsPerParticle < 1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "voxels_per_particle = %d must be >= 1", def->voxelsPerParticle);
	}
	if (def->smallPieces < OD_SMALL_ATTACH || def->smallPieces > OD_SMALL_OWN)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "small_pieces = %d is not a way to treat small pieces", (int)def->smallPieces);
	}
	return od_CheckMesh(def->vertexCount, def->vertices, def->triangleCount, def->triangles, true);
}

typedef struct od_Group
{
	int triangleStart, triangleCount; // its triangles: groupTriangles[triangleStart, + triangleCount)
	bool fill;
	bool open; // one of its pieces is open (an edge in one triangle)
	double area;
	double box[6];    // its bounding box (lowest x, y, z, highest x, y, z)
	double anchor[3]; // the centre of its bounding box
	double length;    // its bounding box's longest side
	bool small;       // fewer voxels than OD_SMALL_PIECE_RATIO of the largest group's, and some area
	bool left;        // small, of its own, but left without particles: attached (od_LeaveOutSmallGroups)
	bool added;       // small, of its own, its OD_SMALL_PIECE_PARTICLES added beyond the budget (the same)
	bool inside;      // small, reaching out of a large group's bounding box less than OD_CARD_REACH of its length
	od_Voxels voxels;
	int particles;
	int first; // the graph index of its first particle
	int host;  // the group its vertices are skinned by (itself when it has particles), or that it is linked to
} od_Group;

typedef struct od_Builder
{
	const od_MeshGraphDef* def;
	od_MeshPieces pieces;
	int groupCount;
	od_Group* groups;
	int* groupOf;        // the group of each piece
	int* groupTriangles; // triangle indices grouped by group
	double* centers; // b->particleCount*3
	double* radii;   // particleCount*3
	double* axes;    // particleCount*9
	int* particleGroup; // particleCount: the group each particle stands for
	int particleCount;  // the graph's: the budget, and the particles added to raise shells to their floor
	od_Buffer edges; // int pairs (i < j)
} od_Builder;

static const int* od_GroupTriangles(const od_Builder* b, const od_Group* g, int* count)
{
	*count = g->triangleCount;
	return b->groupTriangles + g->triangleStart;
}

// The bounding box of a piece's vertices (lo, hi: 3 each).
static void od_PieceBounds(const od_Builder* b, int piece, double* lo, double* hi)
{
	const od_MeshPieces* p = &b->pieces;
	for (int a = 0; a < 3; ++a)
	{
		lo[a] = INFINITY;
		hi[a] = -INFINITY;
	}
	for (int i = p->triangleStart[piece]; i < p->triangleStart[piece + 1]; ++i)
	{
		for (int k = 0; k < 3; ++k)
		{
			const double* x = b->def->vertices + 3 * b->def->triangles[3 * p->triangles[i] + k];
			for (int a = 0; a < 3; ++a)
			{
				lo[a] = fmin(lo[a], x[a]);
				hi[a] = fmax(hi[a], x[a]);
			}
		}
	}
}

// groupOf[p] = the group of piece p: the piece itself, or (joinPieces) one group for the pieces whose
// bounding boxes overlap, directly or through others, so that overlapping parts are voxelized as one solid
// while distant parts keep grids of their own (and are joined by edges afterwards). Groups are numbered by
// their first piece. Returns the number of groups.
static int od_GroupPieces(od_Builder* b, int* groupOf, double* box)
{
	int count = b->pieces.count;
	od_UnionInit(groupOf, count);
	for (int p = 0; p < count && b->def->joinPieces; ++p)
	{
		od_PieceBounds(b, p, box + 6 * p, box + 6 * p + 3);
		for (int q = 0; q < p; ++q)
		{
			bool overlap = true;
			for (int a = 0; a < 3; ++a)
			{
				overlap = overlap && box[6 * p + a] <= box[6 * q + 3 + a] && box[6 * q + a] <= box[6 * p + 3 + a];
			}
			if (overlap)
			{
				od_Union(groupOf, p, q);
			}
		}
	}
	int groups = 0;
	for (int p = 0; p < count; ++p) // roots are the smallest piece of their set, so they come first
	{
		groupOf[p] = od_Find(groupOf, p) == p ? groups++ : groupOf[groupOf[p]];
	}
	return groups;
}

// Each group's anchor: the centre of the bounding box of its pieces (box: scratch of 6 per piece).
static void od_GroupAnchors(od_Builder* b, double* box)
{
	for (int i = 0; i < b->groupCount; ++i)
	{
		double* lo = box + 6 * i;
		for (int a = 0; a < 3; ++a)
		{
			lo[a] = INFINITY;
			lo[3 + a] = -INFINITY;
		}
	}
	for (int p = 0; p < b->pieces.count; ++p)
	{
		double lo[3], hi[3], *group = box + 6 * b->groupOf[p];
		od_PieceBounds(b, p, lo, hi);
		for (int a = 0; a < 3; ++a)
		{
			group[a] = fmin(group[a], lo[a]);
			group[3 + a] = fmax(group[3 + a], hi[a]);
		}
	}
	for (int i = 0; i < b->groupCount; ++i)
	{
		memcpy(b->groups[i].box, box + 6 * i, sizeof(b->groups[i].box));
		for (int a = 0; a < 3; ++a)
		{
			b->groups[i].anchor[a] = 0.5 * (box[6 * i + a] + box[6 * i + 3 + a]);
			b->groups[i].length = fmax(b->groups[i].length, box[6 * i + 3 + a] - box[6 * i + a]);
		}
	}
}

static od_Status od_MakeGroups(od_Builder* b)
{
	const od_MeshGraphDef* def = b->def;
	const od_MeshPieces* pieces = &b->pieces;
	int* groupOf = b->groupOf = od_Alloc(sizeof(int) * (size_t)pieces->count);
	double* box = od_Alloc(sizeof(double) * 6 * (size_t)pieces->count);
	b->groupTriangles = od_Alloc(sizeof(int) * (size_t)def->triangleCount);
	b->groups = od_AllocZero((size_t)pieces->count, sizeof(od_Group));
	if (!groupOf || !box || !b->groupTriangles || !b->groups)
	{
		od_Free(box);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for %d mesh pieces", pieces->count);
	}
	b->groupCount = od_GroupPieces(b, groupOf, box);
	for (int p = 0; p < pieces->count; ++p)
	{
		od_Group* g = &b->groups[groupOf[p]];
		g->triangleCount += pieces->triangleStart[p + 1] - pieces->triangleStart[p];
		g->fill = g->fill || def->mode == OD_MESH_VOLUME || (def->mode != OD_MESH_SURFACE && pieces->closed[p]);
		g->open = g->open || !pieces->closed[p];
		g->area += pieces->area[p];
	}
	od_GroupAnchors(b, box);
	for (int i = 0, start = 0; i < b->groupCount; ++i)
	{
		b->groups[i].triangleStart = start;
		start += b->groups[i].triangleCount;
		b->groups[i].triangleCount = 0; // refilled below
	}
	for (int p = 0; p < pieces->count; ++p)
	{
		od_Group* g = &b->groups[groupOf[p]];
		int n = pieces->triangleStart[p + 1] - pieces->triangleStart[p];
		memcpy(b->groupTriangles + g->triangleStart + g->triangleCount, pieces->triangles + pieces->triangleStart[p],
			   sizeof(int) * (size_t)n);
		g->triangleCount += n;
	}
	od_Free(box);
	return OD_OK;
}

// ---------------------------------------------------------------------------------------------------------
// Resolution

// h from vol u³ + 2 area u² = target voxels (u = 1/h; a shell holds about 2 voxels per h² of area).
static double od_EstimateCellSize(const od_Builder* b, double target, double* exponent)
{
	double volume = 0.0, area = 0.0;
	for (int p = 0; p < b->pieces.count; ++p)
	{
		// Only a closed piece's enclosed volume is known (an open one's signed volume means nothing).
		area += b->pieces.area[p];
		volume += b->def->mode != OD_MESH_SURFACE && b->pieces.closed[p] ? b->pieces.volume[p] : 0.0;
	}
	if (!(area > 0.0))
	{
		// Only degenerate triangles: a line or a point; the correction by counting does the rest.
		double lo[3], hi[3], diag = 0.0;
		for (int a = 0; a < 3; ++a)
		{
			lo[a] = hi[a] = b->def->vertices[a];
		}
		for (int v = 0; v < b->def->vertexCount; ++v)
		{
			for (int a = 0; a < 3; ++a)
			{
				lo[a] = fmin(lo[a], b->def->vertices[3 * v + a]);
				hi[a] = fmax(hi[a], b->def->vertices[3 * v + a]);
			}
		}
		diag = od_Length(od_Sub(od_V3Load(hi), od_V3Load(lo)));
		*exponent = 1.0;
		return diag > 0.0 ? 2.0 * diag / target : 1.0;
	}
	// Newton from above converges monotonically on this increasing convex function.
	double u = (volume > 0.0 ? cbrt(target / volume) : 0.0) + sqrt(target / (2.0 * area));
	for (int it = 0; it < 100; ++it)
	{
		double f = volume * u * u * u + 2.0 * area * u * u - target;
		double step = f / (3.0 * volume * u * u + 4.0 * area * u);
		u -= step;
		if (fabs(step) <= 1e-12 * u)
		{
			break;
		}
	}
	*exponent = volume * u * u * u >= 2.0 * area * u * u ? 3.0 : 2.0;
	return 1.0 / u;
}

// The smallest cell size >= h that keeps every group's grid within OD_VOXEL_CELL_LIMIT and within
// OD_VOXEL_CELLS_PER_VOXEL cells per voxel wanted (target).
static double od_LimitCellSize(const od_Builder* b, double h, double target, bool* limited)
{
	double limit = fmin(OD_VOXEL_CELL_LIMIT, fmax(OD_VOXEL_CELLS_PER_VOXEL * target, OD_VOXEL_CELL_FLOOR));
	for (int i = 0; i < b->groupCount; ++i)
	{
		int count;
		const int* list = od_GroupTriangles(b, &b->groups[i], &count);
		double cells;
		while ((cells = od_Voxels_CellCount(b->def->vertices, b->def->triangles, list, count, h)) > limit)
		{
			h *= fmax(cbrt(cells / limit), 1.01);
			*limited = true;
		}
	}
	return h;
}

static od_Status od_VoxelizeGroups(od_Builder* b, double h, double* total)
{
	*total = 0.0;
	for (int i = 0; i < b->groupCount; ++i)
	{
		od_Group* g = &b->groups[i];
		int count;
		const int* list = od_GroupTriangles(b, g, &count);
		od_Voxels_Destroy(&g->voxels);
		od_Status status = od_Voxelize(b->def->vertices, b->def->triangles, list, count, h, g->fill, &g->voxels);
		if (status != OD_OK)
		{
			return status;
		}
		*total += g->voxels.count;
	}
	return OD_OK;
}

// Voxelizes with the cell size corrected (by the exponent seen so far) until the count is near target.
static od_Status od_ChooseVoxels(od_Builder* b)
{
	double target = (double)b->def->particleCount * b->def->voxelsPerParticle, exponent;
	double h = od_EstimateCellSize(b, target, &exponent), lastH = 0.0, lastCount = 0.0, count = 0.0;
	for (int pass = 0; pass < OD_VOXEL_PASSES; ++pass)
	{
		bool limited = false;
		h = od_LimitCellSize(b, h, target, &limited);
		od_Status status = od_VoxelizeGroups(b, h, &count);
		if (status != OD_OK)
		{
			return status;
		}
		if ((count >= 0.5 * target && count <= 2.0 * target) || (limited && count < target))
		{
			break;
		}
		if (lastCount > 0.0 && count > 0.0 && count != lastCount && h != lastH)
		{
			exponent = fmin(3.0, fmax(1.0, log(count / lastCount) / log(lastH / h)));
		}
		lastH = h;
		lastCount = count;
		h *= count > 0.0 ? pow(count / target, 1.0 / exponent) : 0.25;
	}
	if (count < b->def->particleCount)
	{
		return od_Fail(OD_ERROR_ARGUMENT,
					   "particles = %d: the finest voxel grid allowed holds only %.0f voxels of the mesh (it is "
					   "very thin and spread out); ask for fewer particles",
					   b->def->particleCount, count);
	}
	return OD_OK;
}

// How far the bounding box inner (lowest x, y, z, highest x, y, z) reaches out of the bounding box outer: the
// largest distance along an axis, 0 within it.
static double od_Reach(const double inner[6], const double outer[6])
{
	double reach = 0.0;
	for (int a = 0; a < 3; ++a)
	{
		reach = fmax(reach, fmax(outer[a] - inner[a], inner[3 + a] - outer[3 + a]));
	}
	return reach;
}

// Small groups: fewer voxels than OD_SMALL_PIECE_RATIO of the largest group's, and some area. Measured on
// Blender's Suzanne subdivided twice, each eyeball has 3.2 % of the head's volume: a tenth keeps eyes,
// teeth and buttons well inside, and parts of comparable size (two capsules of 1 and 0.5 m) outside. A
// ratio of voxels depends on neither the mesh's scale nor the particle count, so a piece does not change
// treatment when the particle count does. A piece of no area (a point or a line drawn as degenerate
// triangles) is no surface to carry, and keeps a particle of its own as before.
static void od_MarkSmallGroups(od_Builder* b)
{
	int largest = 0;
	for (int i = 0; i < b->groupCount; ++i)
	{
		largest = b->groups[i].voxels.count > largest ? b->groups[i].voxels.count : largest;
	}
	for (int i = 0; i < b->groupCount; ++i)
	{
		od_Group* g = &b->groups[i];
		g->small = g->area > 0.0 && g->voxels.count < OD_SMALL_PIECE_RATIO * largest;
	}
	for (int i = 0; i < b->groupCount; ++i)
	{
		od_Group* g = &b->groups[i];
		for (int j = 0; j < b->groupCount && g->small; ++j)
		{
			const od_Group* large = &b->groups[j];
			g->inside = g->inside || (!large->small && od_Reach(g->box, large->box) < OD_CARD_REACH * g->length);
		}
	}
}

// Whether a small group of its own is long or flat (its longest side squared over its area above OD_LONG_SHELL,
// an open one's area counted twice as a closed one's two faces) rather than compact (an eye, a button: a sphere's
// is 1/pi): a closed and filled solid (a trunk, an ear plate, a tail, a horn) or an open card that reaches out
// of every large group's bounding box (a hair card, a one-sided wing: OD_CARD_REACH), not an open patch on or
// in one (bpy 5.2's Skin modifier leaves open 25-vertex patches inside gob's body, one 2 cm out of its box at
// the belly: with 16 particles each, painted 0.25, they blew up, 1.9 km off; with 4, 0.04 mm; its body is open
// too, so its voxels are a shell and tell nothing of what lies inside).
// Kept to 4 rigid particles linked all along, the outside bird's cards and wings (docs/goals.md) moved 3.0-19.6
// mm for a rig that flaps the wings 576 mm; as long shells, 29-210 mm (tests/test_loose_parts.py).
static bool od_LongShell(const od_Builder* b, const od_Group* g)
{
	bool shell = g->fill || (g->open && !g->inside);
	double area = g->fill ? g->area : 2.0 * g->area;
	return g->small && shell && b->def->smallPieces == OD_SMALL_OWN && g->length * g->length > OD_LONG_SHELL * area;
}

// Whether a small group gets no particles and is carried rigidly by the nearest large group: all of them with
// OD_SMALL_ATTACH, those left out (od_LeaveOutSmallGroups) with OD_SMALL_OWN.
static bool od_Attached(const od_Builder* b, const od_Group* g)
{
	return g->small && (b->def->smallPieces == OD_SMALL_ATTACH || g->left);
}

// The fewest particles a group gets from the budget before the others get more than that: none for a small
// group that is attached or long (od_ShellParticles), OD_SMALL_PIECE_PARTICLES for a compact small one of its
// own (4 centres span a volume, so its particles can turn it; 3 or fewer, in one plane, let it fold), one
// for the others (never more than its voxels).
static int od_FloorParticles(const od_Builder* b, const od_Group* g)
{
	int own = !od_Attached(b, g) && !od_LongShell(b, g) && !g->added ? OD_SMALL_PIECE_PARTICLES : 0;
	int floor = !g->small ? 1 : own;
	return floor < g->voxels.count ? floor : g->voxels.count;
}

// The particles a long small group of its own has at least (never more than its voxels): its share of the
// budget and, where that is fewer, particles added beyond the budget up to OD_SHELL_PARTICLES, so that its
// look hardly depends on the count: ellie's (docs/goals.md: a trunk, ear plates, a tail, legs) secondary
// motion moved 2.9x over 100-1,000 particles with 4 particles each from the budget (1.57x stretch at 300),
// 1.3x with 16 added. Compact shells keep their 4 from the budget: with 16 for gob's eyes and buttons (7 and
// 4.4 cm) its edges stretched 2.38x at 100 particles (1.20x with 4).
static int od_ShellParticles(const od_Builder* b, const od_Group* g)
{
	int floor = od_LongShell(b, g) ? OD_SHELL_PARTICLES : g->added ? OD_SMALL_PIECE_PARTICLES : 0;
	return floor < g->voxels.count ? floor : g->voxels.count;
}

// The compact or open small groups of their own take OD_SMALL_PIECE_PARTICLES each from the budget before a
// large group gets a second particle: 300 loose 4 cm cubes beside a 1 m box left the box 1 particle of 100, and
// the cubes beyond the 99th particle were skinned by other cubes' particles up to 1 m away. Their floors now take
// at most OD_SMALL_PIECE_SHARE of the budget, largest first; the next ones get theirs added beyond the budget, at
// most OD_SMALL_PIECE_EXTRA of it (the body keeps its half, and the outside dancer's 10 hair ribbons past its 12
// skirt cards' 48 of 100 got 4 each, 140 built, where left out they rode the head: docs/goals.md, "Cards and
// ribbons (stop 50)"); the groups past that are left out, attached to the nearest large group (as with
// OD_SMALL_ATTACH), and reported as such by the add-on. Typical parts stay well inside it: Suzanne's eyes take 8
// of 100, the kid's skirt and backpack 8 of 50 (docs/goals.md).
static od_Status od_LeaveOutSmallGroups(od_Builder* b)
{
	int* order = od_Alloc(sizeof(int) * 2 * (size_t)b->groupCount); // (-voxels, group): largest first
	if (!order)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for %d mesh pieces", b->groupCount);
	}
	int count = 0;
	for (int i = 0; i < b->groupCount; ++i)
	{
		if (b->groups[i].small && od_FloorParticles(b, &b->groups[i]) > 0)
		{
			order[2 * count] = -b->groups[i].voxels.count;
			order[2 * count + 1] = i;
			++count;
		}
	}
	od_Status status = od_Sort(order, (size_t)count, sizeof(int) * 2, od_CompareIntPairs);
	int given = 0;
	bool full = false, over = false;
	for (int k = 0; k < count && status == OD_OK; ++k)
	{
		od_Group* g = &b->groups[order[2 * k + 1]];
		int floor = od_FloorParticles(b, g);
		full = full || given + floor > OD_SMALL_PIECE_SHARE * b->def->particleCount;
		over = over || given + floor > (OD_SMALL_PIECE_SHARE + OD_SMALL_PIECE_EXTRA) * b->def->particleCount;
		g->added = full && !over;
		g->left = over;
		given += floor;
	}
	od_Free(order);
	return status;
}

// Particles to the groups below their floor first (largest first), then each to the group furthest below
// its share (in proportion to voxels); attached small groups and those given theirs beyond the budget only when no
// other group has voxels left. Then the small groups of their own are raised to od_ShellParticles beyond the
// budget (b->particleCount: all).
static void od_ShareParticles(od_Builder* b)
{
	double total = 0.0;
	for (int i = 0; i < b->groupCount; ++i)
	{
		total += b->groups[i].voxels.count;
	}
	for (int given = 0; given < b->def->particleCount; ++given)
	{
		int best = -1;
		double bestKey = -INFINITY;
		for (int i = 0; i < b->groupCount; ++i)
		{
			const od_Group* g = &b->groups[i];
			if (g->particles >= g->voxels.count)
			{
				continue;
			}
			double key = b->def->particleCount * (g->voxels.count / total) - g->particles; // below its share
			if (g->particles < od_FloorParticles(b, g))
			{
				key = 1e18 + g->voxels.count;
			}
			else if (od_Attached(b, g) || g->added)
			{
				key = -1e18;
			}
			if (key > bestKey)
			{
				bestKey = key;
				best = i;
			}
		}
		b->groups[best].particles++;
	}
	b->particleCount = 0;
	for (int i = 0; i < b->groupCount; ++i)
	{
		od_Group* g = &b->groups[i];
		if (g->particles < od_ShellParticles(b, g))
		{
			g->particles = od_ShellParticles(b, g);
		}
		g->first = b->particleCount;
		b->particleCount += g->particles;
	}
}

// ---------------------------------------------------------------------------------------------------------
// Cells of one group

typedef struct od_HeapItem
{
	double d;
	int v;
} od_HeapItem;

typedef struct od_Cells
{
	const od_Voxels* voxels;
	int count;      // voxels
	int k;          // cells
	int* map;       // grid cell -> voxel index, or -1
	double* pos;    // count*3 voxel centres
	int* label;     // count, the cell of each voxel (-1: none reached)
	double* dist;   // count, geodesic distance to the cell's seed
	int* seeds;     // k
	double* mean;   // k*3
	double* cov;    // k*9
	double* size;   // k, the weight of each cell (shell voxels count half)
	double* best;   // k, scratch
	int* nearest;   // k, scratch
	od_Buffer heap;  // od_HeapItem: Dijkstra's queue, nearest first
	int offset[26]; // linear offsets of the 26 neighbours; the first 13 point forwards
	double step[26];
} od_Cells;

static int od_HeapLess(od_HeapItem a, od_HeapItem b)
{
	return a.d < b.d || (a.d == b.d && a.v < b.v);
}

// A binary heap of od_HeapItem in a buffer, least (d, v) first.
static od_Status od_HeapPush(od_Buffer* buffer, double d, int v)
{
	od_Status status = od_BufferReserve(buffer, sizeof(od_HeapItem));
	if (status != OD_OK)
	{
		return status;
	}
	od_HeapItem* heap = (od_HeapItem*)buffer->data;
	od_HeapItem item = { d, v };
	size_t i = buffer->size / sizeof item;
	buffer->size += sizeof item;
	while (i > 0 && od_HeapLess(item, heap[(i - 1) / 2]))
	{
		heap[i] = heap[(i - 1) / 2];
		i = (i - 1) / 2;
	}
	heap[i] = item;
	return OD_OK;
}

static od_HeapItem od_HeapPop(od_Buffer* buffer)
{
	od_HeapItem* heap = (od_HeapItem*)buffer->data;
	buffer->size -= sizeof(od_HeapItem);
	size_t count = buffer->size / sizeof(od_HeapItem), i = 0;
	od_HeapItem top = heap[0], last = heap[count];
	for (;;)
	{
		size_t child = 2 * i + 1;
		if (child >= count)
		{
			break;
		}
		if (child + 1 < count && od_HeapLess(heap[child + 1], heap[child]))
		{
			++child;
		}
		if (!od_HeapLess(heap[child], last))
		{
			break;
		}
		heap[i] = heap[child];
		i = child;
	}
	heap[i] = last;
	return top;
}

// Dijkstra from what is queued: a voxel joins the cell of the first seed that reaches it strictly closer.
// Polls for interrupts every OD_SPREAD_POLL + 1 voxels taken from the queue.
static od_Status od_Spread(od_Cells* c)
{
	const int* cells = c->voxels->cells;
	for (unsigned taken = 0; c->heap.size > 0; ++taken)
	{
		od_Status polled = (taken & OD_SPREAD_POLL) == 0 ? od_CheckInterrupt() : OD_OK;
		if (polled != OD_OK)
		{
			return polled;
		}
		od_HeapItem top = od_HeapPop(&c->heap);
		if (top.d > c->dist[top.v])
		{
			continue;
		}
		for (int n = 0; n < 26; ++n)
		{
			int u = c->map[cells[top.v] + c->offset[n]];
			double d = top.d + c->step[n];
			if (u >= 0 && d < c->dist[u])
			{
				c->dist[u] = d;
				c->label[u] = c->label[top.v];
				od_Status status = od_HeapPush(&c->heap, d, u);
				if (status != OD_OK)
				{
					return status;
				}
			}
		}
	}
	return OD_OK;
}

static od_Status od_Seed(od_Cells* c, int cell, int voxel)
{
	c->seeds[cell] = voxel;
	c->dist[voxel] = 0.0;
	c->label[voxel] = cell;
	return od_HeapPush(&c->heap, 0.0, voxel);
}

static void od_ClearCells(od_Cells* c)
{
	for (int i = 0; i < c->count; ++i)
	{
		c->label[i] = -1;
		c->dist[i] = INFINITY;
	}
}

// The cell of voxel i: its label, or 0 for every voxel when label is NULL (the whole group as one).
static int od_CellOfVoxel(const int* label, int i)
{
	return label ? label[i] : 0;
}

// The weight of voxel i in the moments: a voxel that a triangle crosses is on average half inside the body.
static double od_VoxelWeight(const od_Cells* c, int i)
{
	return c->voxels->shell[i] ? 0.5 : 1.0;
}

// Weighted means, covariances (of the voxel centres) and weights of the cells (c->mean, c->cov, c->size).
static void od_CellMoments(od_Cells* c, const int* label, int k)
{
	memset(c->mean, 0, sizeof(double) * 3 * (size_t)k);
	memset(c->cov, 0, sizeof(double) * 9 * (size_t)k);
	memset(c->size, 0, sizeof(double) * (size_t)k);
	for (int i = 0; i < c->count; ++i)
	{
		int l = od_CellOfVoxel(label, i);
		if (l >= 0)
		{
			c->size[l] += od_VoxelWeight(c, i);
			od_V3Store(c->mean + 3 * l, od_MulAdd(od_V3Load(c->mean + 3 * l), od_VoxelWeight(c, i),
												  od_V3Load(c->pos + 3 * i)));
		}
	}
	for (int l = 0; l < k; ++l)
	{
		od_V3Store(c->mean + 3 * l, od_Scale(1.0 / (c->size[l] > 0.0 ? c->size[l] : 1.0), od_V3Load(c->mean + 3 * l)));
	}
	for (int i = 0; i < c->count; ++i)
	{
		int l = od_CellOfVoxel(label, i);
		if (l >= 0)
		{
			od_Vec3 d = od_Sub(od_V3Load(c->pos + 3 * i), od_V3Load(c->mean + 3 * l));
			od_Mat3 cov = od_M3Load(c->cov + 9 * l);
			od_M3AddOuter(&cov, od_VoxelWeight(c, i) / c->size[l], d, d);
			od_M3Store(c->cov + 9 * l, &cov);
		}
	}
}

// For each cell, its voxel nearest to its mean, lowest index on ties; returns whether a seed moved.
static bool od_SeedsNearMeans(od_Cells* c, const int* label, int k)
{
	for (int l = 0; l < k; ++l)
	{
		c->best[l] = INFINITY;
		c->nearest[l] = c->seeds[l]; // a cell left without voxels keeps its seed
	}
	for (int i = 0; i < c->count; ++i)
	{
		int l = od_CellOfVoxel(label, i);
		if (l < 0)
		{
			continue;
		}
		od_Vec3 d = od_Sub(od_V3Load(c->pos + 3 * i), od_V3Load(c->mean + 3 * l));
		double d2 = od_Dot(d, d);
		if (d2 < c->best[l])
		{
			c->best[l] = d2;
			c->nearest[l] = i;
		}
	}
	bool moved = false;
	for (int l = 0; l < k; ++l)
	{
		moved = moved || c->seeds[l] != c->nearest[l];
		c->seeds[l] = c->nearest[l];
	}
	return moved;
}

// The voxel's integer coordinate along an axis.
static int od_VoxelCoordinate(const od_Cells* c, int i, int axis)
{
	int cell = c->voxels->cells[i];
	const int* dims = c->voxels->dims;
	return axis == 0 ? cell % dims[0] : axis == 1 ? (cell / dims[0]) % dims[1] : cell / (dims[0] * dims[1]);
}

// Splits the voxels order[begin, end) into `parts` cells labelled from `first`, of nearly equal voxel count,
// by cuts across the longest extent (a k-d split; stable counting sorts on the integer voxel coordinates,
// so O(voxels) per level and deterministic). `sorted` is scratch of the size of order, `slots` of
// max(dims) + 1.
static void od_SplitCells(od_Cells* c, int* order, int* sorted, int* slots, int begin, int end, int parts, int first)
{
	if (parts == 1)
	{
		for (int i = begin; i < end; ++i)
		{
			c->label[order[i]] = first;
		}
		return;
	}
	int lo[3] = { INT_MAX, INT_MAX, INT_MAX }, hi[3] = { INT_MIN, INT_MIN, INT_MIN }, axis = 0;
	for (int i = begin; i < end; ++i)
	{
		for (int a = 0; a < 3; ++a)
		{
			int x = od_VoxelCoordinate(c, order[i], a);
			lo[a] = x < lo[a] ? x : lo[a];
			hi[a] = x > hi[a] ? x : hi[a];
		}
	}
	for (int a = 1; a < 3; ++a)
	{
		axis = hi[a] - lo[a] > hi[axis] - lo[axis] ? a : axis;
	}
	int span = hi[axis] - lo[axis] + 1;
	memset(slots, 0, sizeof(int) * (size_t)(span + 1));
	for (int i = begin; i < end; ++i)
	{
		slots[od_VoxelCoordinate(c, order[i], axis) - lo[axis] + 1]++;
	}
	for (int x = 0; x < span; ++x)
	{
		slots[x + 1] += slots[x];
	}
	for (int i = begin; i < end; ++i)
	{
		sorted[begin + slots[od_VoxelCoordinate(c, order[i], axis) - lo[axis]]++] = order[i];
	}
	memcpy(order + begin, sorted + begin, sizeof(int) * (size_t)(end - begin));
	int left = parts / 2, mid = begin + (int)((long long)(end - begin) * left / parts);
	od_SplitCells(c, order, sorted, slots, begin, mid, left, first);
	od_SplitCells(c, order, sorted, slots, mid, end, parts - left, first + left);
}

static od_Status od_GeodesicCells(od_Cells* c)
{
	// Seeds: the voxel nearest the centroid of each part of a k-d split, then cells grown from them.
	const int* dims = c->voxels->dims;
	int longest = dims[0] > dims[1] ? dims[0] : dims[1];
	longest = longest > dims[2] ? longest : dims[2];
	int* order = od_Alloc(sizeof(int) * (size_t)c->count);
	int* sorted = od_Alloc(sizeof(int) * (size_t)c->count);
	int* slots = od_Alloc(sizeof(int) * ((size_t)longest + 1));
	if (!order || !sorted || !slots)
	{
		od_Free(order);
		od_Free(sorted);
		od_Free(slots);
		return od_Fail(OD_ERROR_MEMORY, "out of memory splitting %d voxels", c->count);
	}
	for (int i = 0; i < c->count; ++i)
	{
		order[i] = i;
	}
	od_SplitCells(c, order, sorted, slots, 0, c->count, c->k, 0);
	od_Free(order);
	od_Free(sorted);
	od_Free(slots);
	od_CellMoments(c, c->label, c->k);
	od_SeedsNearMeans(c, c->label, c->k);
	od_ClearCells(c);
	od_Status status = OD_OK;
	for (int l = 0; l < c->k && status == OD_OK; ++l)
	{
		status = od_Seed(c, l, c->seeds[l]);
	}
	status = status == OD_OK ? od_Spread(c) : status;
	if (status != OD_OK)
	{
		return status;
	}
	// Lloyd steps.
	for (int step = 0; step < OD_LLOYD_STEPS; ++step)
	{
		od_CellMoments(c, c->label, c->k);
		if (!od_SeedsNearMeans(c, c->label, c->k))
		{
			break;
		}
		od_ClearCells(c);
		for (int l = 0; l < c->k && status == OD_OK; ++l)
		{
			status = od_Seed(c, l, c->seeds[l]);
		}
		status = status == OD_OK ? od_Spread(c) : status;
		if (status != OD_OK)
		{
			return status;
		}
	}
	return OD_OK;
}

static int od_CompareProjections(const void* pa, const void* pb)
{
	const double *a = pa, *b = pb; // (projection, index)
	if (a[0] != b[0])
	{
		return a[0] < b[0] ? -1 : 1;
	}
	return (a[1] > b[1]) - (a[1] < b[1]);
}

// Eigenvalues (descending) and eigenvectors (columns, a proper rotation) of a covariance.
static void od_PrincipalAxes(const double* cov, od_Vec3* values, od_Mat3* frame)
{
	od_Mat3 a = od_M3Load(cov), u;
	od_Svd3(&a, &u, values, frame);
}

// Slabs along the principal axis of the group: of equal length over its voxels' extent (whole columns of
// voxels stay together, so a straight bar gets its particles on its axis), or, where that leaves a slab
// empty (a bent or gapped body), of equal voxel count.
static od_Status od_ChainCells(od_Cells* c)
{
	od_Vec3 values;
	od_Mat3 frame;
	od_CellMoments(c, NULL, 1);
	od_PrincipalAxes(c->cov, &values, &frame);
	od_Vec3 axis = od_V3(frame.m[0], frame.m[3], frame.m[6]);
	double* order = od_Alloc(sizeof(double) * 2 * (size_t)c->count); // (projection, index)
	if (!order)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory ordering %d voxels", c->count);
	}
	double lo = INFINITY, hi = -INFINITY;
	for (int i = 0; i < c->count; ++i)
	{
		order[2 * i] = od_Dot(axis, od_V3Load(c->pos + 3 * i));
		order[2 * i + 1] = i;
		lo = fmin(lo, order[2 * i]);
		hi = fmax(hi, order[2 * i]);
	}
	double start = lo - 0.5 * c->voxels->h, length = hi - lo + c->voxels->h;
	memset(c->size, 0, sizeof(double) * (size_t)c->k);
	for (int i = 0; i < c->count; ++i)
	{
		int l = (int)floor((order[2 * i] - start) / length * c->k);
		c->label[i] = l < 0 ? 0 : l >= c->k ? c->k - 1 : l;
		c->size[c->label[i]] += 1.0;
	}
	bool empty = false;
	for (int l = 0; l < c->k; ++l)
	{
		empty = empty || c->size[l] == 0.0;
	}
	if (empty)
	{
		qsort(order, (size_t)c->count, sizeof(double) * 2, od_CompareProjections);
		for (int r = 0; r < c->count; ++r)
		{
			c->label[(int)order[2 * r + 1]] = (int)((long long)r * c->k / c->count);
		}
	}
	od_Free(order);
	return OD_OK;
}

// ---------------------------------------------------------------------------------------------------------
// Particles and edges of one group

static void od_FitParticles(od_Builder* b, od_Cells* c, const od_Group* g)
{
	od_CellMoments(c, c->label, c->k);
	double h2 = g->voxels.h * g->voxels.h / 12.0;
	for (int l = 0; l < c->k; ++l)
	{
		od_Vec3 values;
		od_Mat3 frame;
		od_PrincipalAxes(c->cov + 9 * l, &values, &frame);
		int p = g->first + l;
		memcpy(b->centers + 3 * p, c->mean + 3 * l, sizeof(double) * 3);
		b->radii[3 * p] = sqrt(5.0 * (fmax(values.x, 0.0) + h2));
		b->radii[3 * p + 1] = sqrt(5.0 * (fmax(values.y, 0.0) + h2));
		b->radii[3 * p + 2] = sqrt(5.0 * (fmax(values.z, 0.0) + h2));
		od_M3Store(b->axes + 9 * p, &frame);
	}
}

static od_Status od_AddEdge(od_Builder* b, int i, int j)
{
	int e[2] = { i < j ? i : j, i < j ? j : i };
	return od_BufferAppend(&b->edges, e, sizeof e);
}

static int od_EdgeCount(const od_Builder* b)
{
	return (int)(b->edges.size / (2 * sizeof(int)));
}

// Edges between cells whose voxels touch: faceOnly, every such pair; otherwise only pairs that join
// parts not yet connected (by a voxel edge or corner). parent holds the parts (local cell indices).
static od_Status od_TouchingCells(od_Builder* b, const od_Cells* c, int first, bool faceOnly, int* parent)
{
	for (int i = 0; i < c->count; ++i)
	{
		int a = c->label[i];
		for (int n = 0; n < 13 && a >= 0; ++n)
		{
			int j = c->map[c->voxels->cells[i] + c->offset[n]];
			int l = j >= 0 ? c->label[j] : -1;
			if (l < 0 || l == a || (faceOnly ? c->step[n] != 1.0 : od_Find(parent, a) == od_Find(parent, l)))
			{
				continue;
			}
			od_Union(parent, a, l);
			od_Status status = od_AddEdge(b, first + a, first + l);
			if (status != OD_OK)
			{
				return status;
			}
		}
	}
	return OD_OK;
}

// Borůvka: while the particles first..first+k form several parts (parent: their sets, local indices), join
// every part to its nearest other part (pairs ordered by (distance, i, j), a strict order: no cycle forms).
static od_Status od_ConnectParts(od_Builder* b, int first, int k, int* parent)
{
	int* best = od_Alloc(sizeof(int) * 2 * (size_t)k);
	double* bestD = od_Alloc(sizeof(double) * (size_t)k);
	if (!best || !bestD)
	{
		od_Free(best);
		od_Free(bestD);
		return od_Fail(OD_ERROR_MEMORY, "out of memory joining %d particles", k);
	}
	od_Status status = OD_OK;
	for (bool joined = true; joined && status == OD_OK;)
	{
		joined = false;
		for (int i = 0; i < k; ++i)
		{
			bestD[i] = INFINITY;
		}
		for (int i = 0; i < k; ++i)
		{
			for (int j = i + 1; j < k; ++j)
			{
				int pi = od_Find(parent, i), pj = od_Find(parent, j);
				if (pi == pj)
				{
					continue;
				}
				double d = od_Length(od_Sub(od_V3Load(b->centers + 3 * (first + i)),
											od_V3Load(b->centers + 3 * (first + j))));
				int part[2] = { pi, pj };
				for (int s = 0; s < 2; ++s)
				{
					if (d < bestD[part[s]]) // i, j ascending: the first of equal pairs stays
					{
						bestD[part[s]] = d;
						best[2 * part[s]] = i;
						best[2 * part[s] + 1] = j;
					}
				}
			}
		}
		for (int p = 0; p < k && status == OD_OK; ++p)
		{
			if (bestD[p] < INFINITY && od_Union(parent, best[2 * p], best[2 * p + 1]))
			{
				status = od_AddEdge(b, first + best[2 * p], first + best[2 * p + 1]);
				joined = true;
			}
		}
	}
	od_Free(best);
	od_Free(bestD);
	return status;
}

static od_Status od_GroupEdges(od_Builder* b, const od_Cells* c, const od_Group* g)
{
	int* parent = od_Alloc(sizeof(int) * (size_t)c->k);
	if (!parent)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the edges of %d particles", c->k);
	}
	od_UnionInit(parent, c->k);
	od_Status status = OD_OK;
	if (b->def->mode == OD_MESH_CHAIN)
	{
		for (int l = 0; l + 1 < c->k && status == OD_OK; ++l)
		{
			od_Union(parent, l, l + 1);
			status = od_AddEdge(b, g->first + l, g->first + l + 1);
		}
	}
	else
	{
		int before = od_EdgeCount(b);
		status = od_TouchingCells(b, c, g->first, true, parent);
		if (status == OD_OK)
		{
			// The face pairs, sorted and without repeats.
			int* edges = (int*)b->edges.data;
			int count = od_EdgeCount(b), unique = before;
			if (count > before) // no edges yet: edges may be NULL, and NULL + 0 or qsort(NULL) is undefined
			{
				qsort(edges + 2 * before, (size_t)(count - before), sizeof(int) * 2, od_CompareIntPairs);
			}
			for (int e = before; e < count; ++e)
			{
				if (unique == before || od_CompareIntPairs(edges + 2 * e, edges + 2 * (unique - 1)) != 0)
				{
					memmove(edges + 2 * unique++, edges + 2 * e, sizeof(int) * 2);
				}
			}
			b->edges.size = (size_t)unique * 2 * sizeof(int);
			status = od_TouchingCells(b, c, g->first, false, parent);
		}
	}
	status = status == OD_OK ? od_ConnectParts(b, g->first, g->particles, parent) : status;
	od_Free(parent);
	return status;
}

static void od_NeighborOffsets(od_Cells* c)
{
	const int* dims = c->voxels->dims;
	int forward = 0, backward = 13;
	for (int dz = -1; dz <= 1; ++dz)
	{
		for (int dy = -1; dy <= 1; ++dy)
		{
			for (int dx = -1; dx <= 1; ++dx)
			{
				int linear = (dz * dims[1] + dy) * dims[0] + dx;
				if (linear == 0)
				{
					continue;
				}
				int n = linear > 0 ? forward++ : backward++;
				c->offset[n] = linear;
				c->step[n] = sqrt((double)(dx * dx + dy * dy + dz * dz));
			}
		}
	}
}

static od_Status od_BuildGroup(od_Builder* b, const od_Group* g)
{
	const od_Voxels* vox = &g->voxels;
	size_t cells = (size_t)vox->dims[0] * vox->dims[1] * vox->dims[2];
	od_Cells c;
	memset(&c, 0, sizeof c);
	c.voxels = vox;
	c.count = vox->count;
	c.k = g->particles;
	c.map = od_Alloc(sizeof(int) * cells);
	c.pos = od_Alloc(sizeof(double) * 3 * (size_t)c.count);
	c.label = od_Alloc(sizeof(int) * (size_t)c.count);
	c.dist = od_Alloc(sizeof(double) * (size_t)c.count);
	c.seeds = od_AllocZero((size_t)c.k, sizeof(int)); // read before the first seeding: compare defined values
	c.mean = od_Alloc(sizeof(double) * 3 * (size_t)c.k);
	c.cov = od_Alloc(sizeof(double) * 9 * (size_t)c.k);
	c.size = od_Alloc(sizeof(double) * (size_t)c.k);
	c.best = od_Alloc(sizeof(double) * (size_t)c.k);
	c.nearest = od_Alloc(sizeof(int) * (size_t)c.k);
	od_Status status = OD_OK;
	if (!c.map || !c.pos || !c.label || !c.dist || !c.seeds || !c.mean || !c.cov || !c.size || !c.best || !c.nearest)
	{
		status = od_Fail(OD_ERROR_MEMORY, "out of memory for %d voxels", c.count);
	}
	else
	{
		memset(c.map, 0xff, sizeof(int) * cells); // -1
		for (int i = 0; i < c.count; ++i)
		{
			c.map[vox->cells[i]] = i;
			od_Voxels_Center(vox, i, c.pos + 3 * i);
		}
		od_NeighborOffsets(&c);
		status = b->def->mode == OD_MESH_CHAIN ? od_ChainCells(&c) : od_GeodesicCells(&c);
	}
	if (status == OD_OK)
	{
		od_FitParticles(b, &c, g);
		status = od_GroupEdges(b, &c, g);
	}
	od_Free(c.map);
	od_Free(c.pos);
	od_Free(c.label);
	od_Free(c.dist);
	od_Free(c.seeds);
	od_Free(c.mean);
	od_Free(c.cov);
	od_Free(c.size);
	od_Free(c.best);
	od_Free(c.nearest);
	od_Free(c.heap.data);
	return status;
}

// ---------------------------------------------------------------------------------------------------------

// Joined pieces that were voxelized apart (far from each other): edges between the nearest particles.
static od_Status od_JoinGroups(od_Builder* b)
{
	int n = b->particleCount;
	int* parent = od_Alloc(sizeof(int) * (size_t)n);
	if (!parent)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory joining %d particles", n);
	}
	od_UnionInit(parent, n);
	const int* edges = (const int*)b->edges.data;
	for (int e = 0; e < od_EdgeCount(b); ++e)
	{
		od_Union(parent, edges[2 * e], edges[2 * e + 1]);
	}
	od_Status status = od_ConnectParts(b, 0, n, parent);
	od_Free(parent);
	return status;
}

// ---------------------------------------------------------------------------------------------------------
// Small pieces and the map of mesh pieces

// The group of the particle nearest p (with `large`: among the particles i with large[i] == 1).
static int od_NearestGroup(const od_Builder* b, const double* p, const int* large)
{
	int nearest = 0;
	double d;
	od_NearestBrute(b->centers, b->particleCount, large, 1, p, 1, &d, &nearest);
	return b->particleGroup[nearest];
}

// Whether a long small group of its own lies along a line (a tail, a trunk, a hanging ear: its particles' spread
// along their longest principal axis at least OD_BEAM_SHELL times that along the next) rather than across a
// plane (an ear plate).
static bool od_BeamShell(const od_Builder* b, const od_Group* g)
{
	const double* c = b->centers + 3 * g->first;
	od_Vec3 mean = od_V3(0, 0, 0), values;
	for (int i = 0; i < g->particles; ++i)
	{
		mean = od_MulAdd(mean, 1.0 / g->particles, od_V3Load(c + 3 * i));
	}
	od_Mat3 cov = { { 0.0 } }, frame;
	for (int i = 0; i < g->particles; ++i)
	{
		od_Vec3 d = od_Sub(od_V3Load(c + 3 * i), mean);
		od_M3AddOuter(&cov, 1.0, d, d);
	}
	od_PrincipalAxes(cov.m, &values, &frame);
	return od_LongShell(b, g) && values.x >= OD_BEAM_SHELL * OD_BEAM_SHELL * values.y;
}

// The index of the smallest of the non-negative distance[0..n) (the first of equals).
static int od_Closest(const double* distance, int n)
{
	int best = -1;
	for (int i = 0; i < n; ++i)
	{
		best = distance[i] >= 0.0 && (best < 0 || distance[i] < distance[best]) ? i : best;
	}
	return best;
}

// Whether a small group of its own moves as a rigid body: compact or an open patch, with no more than its floor of
// particles (a button, an eye at a low count: particles about as large as the piece), its vertices share its
// anchor's weights over its particles (graph/piece_map.c). Skinned each by its nearest, gob's 44 mm buttons
// at 50 particles (docs/goals.md) stretched 1.72x when the landing moved their four particles apart (their
// links to the body pulled two ways); rigid, 1.02x, swinging as far (124.2 mm). Linking all four to one body
// particle instead gave 1.05x too, but Suzanne's eyes at 100 particles left their sockets by 0.2 % of the
// head's size against 0.04 % (tests/test_loose_parts.py); rigid, 0.04 %.
static bool od_Rigid(const od_Builder* b, const od_Group* g)
{
	return g->small && g->particles > 0 && g->particles <= OD_SMALL_PIECE_PARTICLES && !od_LongShell(b, g);
}

// Whether a group is a sheet, whose vertices the mesh skin blends over more particles (OD_SHEET_SKIN): open, of
// its own (not small: an open patch of a few vertices keeps to its few particles) and not the group with the
// most voxels (the body; materials._sheets_floored calls the same pieces sheets).
static bool od_Sheet(const od_Builder* b, const od_Group* g)
{
	bool largest = true;
	for (int i = 0; i < b->groupCount; ++i)
	{
		largest = largest && b->groups[i].voxels.count <= g->voxels.count;
	}
	return g->open && !g->small && g->particles > 0 && !largest;
}

// Edges from the particles of group g to the nearest particle of group host each: from every particle, or,
// for a shell along a line (od_BeamShell), from the OD_ROOT_LINKS nearest the host only (its root; ties by
// index). Linked all along, the dog's hanging ears (docs/goals.md) moved 0.03 mm against the rig's 155 mm:
// each link is held by the host particle's volume and stiffness, which outweigh the shell's own (the ears 100
// times softer moved the same); linked at the root, 41 mm. A closed plate keeps every link: a single layer of
// particles does not hold its shape by itself (ellie's ear plates, linked at the root: 515 mm, 2.9x stretch).
// An open card (od_LongShell: a hair card, a one-sided wing) is linked at its root, with its own k
// (materials._own_cards): the outside bird's wings linked all along swung 17.6 mm, at the root 159 mm.
static od_Status od_LinkGroup(od_Builder* b, const od_Group* g, int host)
{
	int n = g->particles;
	double* distance = od_Alloc(sizeof(double) * (size_t)n);
	int* nearest = od_Alloc(sizeof(int) * (size_t)n);
	od_Status status = distance && nearest ? OD_OK : od_Fail(OD_ERROR_MEMORY, "out of memory linking %d particles", n);
	for (int i = 0; i < n && status == OD_OK; ++i)
	{
		const double* p = b->centers + 3 * (g->first + i);
		od_NearestBrute(b->centers, b->particleCount, b->particleGroup, host, p, 1, &distance[i], &nearest[i]);
	}
	bool root = (od_BeamShell(b, g) || (g->open && od_LongShell(b, g))) && n > OD_ROOT_LINKS;
	for (int l = 0; l < (root ? OD_ROOT_LINKS : n) && status == OD_OK; ++l)
	{
		int i = root ? od_Closest(distance, n) : l;
		distance[i] = -1.0; // linked
		status = od_AddEdge(b, g->first + i, nearest[i]);
	}
	od_Free(distance);
	od_Free(nearest);
	return status;
}

// Each group's host: itself when it has particles; else (attached small groups, and groups left without a
// particle when there were fewer particles than groups) the large group of the particle nearest its anchor,
// whose particles then skin it (not a small group's: a cube among 300 rode another cube 1 m away). A small
// group of its own is linked by edges, from each of its particles to the nearest one of the large group
// nearest its anchor: on its own it is a free body, which on
// Suzanne (tests/test_loose_parts.py) kept falling through the head when the head landed: the eyes left
// their sockets by 39 % and 35 % of the head's size at 100 and 1,000 particles; linked, 0.03 % and 0.8 %.
static od_Status od_HostGroups(od_Builder* b)
{
	int n = b->particleCount;
	int* large = od_Alloc(sizeof(int) * (size_t)n);
	if (!large)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for %d particles", n);
	}
	for (int i = 0; i < n; ++i)
	{
		large[i] = !b->groups[b->particleGroup[i]].small;
	}
	od_Status status = OD_OK;
	for (int i = 0; i < b->groupCount && status == OD_OK; ++i)
	{
		od_Group* g = &b->groups[i];
		g->host = g->particles > 0 ? i : od_NearestGroup(b, g->anchor, large);
		if (g->small && g->particles > 0)
		{
			status = od_LinkGroup(b, g, od_NearestGroup(b, g->anchor, large));
		}
	}
	od_Free(large);
	return status;
}

// Gives the graph its map of mesh pieces (graph/piece_map.c): the group of each particle, each group's
// host and anchor, and (several groups) every vertex used by a triangle with its group.
static od_Status od_RecordPieces(od_Builder* b, od_Graph* graph)
{
	const od_MeshGraphDef* def = b->def;
	int used = 0, groups = b->groupCount;
	int* host = od_Alloc(sizeof(int) * (size_t)groups);
	double* anchors = od_Alloc(sizeof(double) * 3 * (size_t)groups);
	bool* rigid = od_Alloc(sizeof(bool) * (size_t)groups);
	bool* sheet = od_Alloc(sizeof(bool) * (size_t)groups);
	double* points = od_Alloc(sizeof(double) * 3 * (size_t)def->vertexCount);
	int* pointGroup = od_Alloc(sizeof(int) * (size_t)def->vertexCount);
	od_Status status = host && anchors && rigid && sheet && points && pointGroup
						   ? OD_OK
						   : od_Fail(OD_ERROR_MEMORY, "out of memory for the pieces of %d vertices", def->vertexCount);
	for (int i = 0; i < groups && status == OD_OK; ++i)
	{
		host[i] = b->groups[i].host;
		rigid[i] = od_Rigid(b, &b->groups[i]);
		sheet[i] = od_Sheet(b, &b->groups[i]);
		memcpy(anchors + 3 * i, b->groups[i].anchor, sizeof(double) * 3);
	}
	for (int v = 0; v < def->vertexCount && status == OD_OK && groups > 1; ++v)
	{
		int piece = b->pieces.pieceOfVertex[v];
		if (piece >= 0)
		{
			memcpy(points + 3 * used, def->vertices + 3 * v, sizeof(double) * 3);
			pointGroup[used++] = b->groupOf[piece];
		}
	}
	if (status == OD_OK)
	{
		od_PieceMapDef map = { .pieceCount = groups, .particlePiece = b->particleGroup, .host = host,
							   .anchors = anchors, .rigid = rigid, .sheet = sheet, .pointCount = used, .points = points,
							   .pointPiece = pointGroup };
		status = od_Graph_SetMeshPieces(graph, &map);
	}
	od_Free(host);
	od_Free(anchors);
	od_Free(rigid);
	od_Free(sheet);
	od_Free(points);
	od_Free(pointGroup);
	return status;
}

static od_Status od_Build(od_Builder* b, od_Graph** graph)
{
	int n = b->def->particleCount;
	od_Status status = od_MeshPieces_Find(b->def, &b->pieces);
	if (status != OD_OK)
	{
		return status;
	}
	if (b->pieces.distinctVertices < n)
	{
		double span = b->pieces.span;
		return od_Fail(OD_ERROR_ARGUMENT,
					   "particles = %d, but the mesh has only %d distinct vertices: it spans %g m (the diagonal of its "
					   "bounding box) and vertices closer than %g of that (%g m) are welded into one; is a vertex far "
					   "from the others?",
					   n, b->pieces.distinctVertices, span, OD_WELD_FRACTION, span * OD_WELD_FRACTION);
	}
	status = od_MakeGroups(b);
	status = status == OD_OK ? od_ChooseVoxels(b) : status;
	if (status != OD_OK)
	{
		return status;
	}
	od_MarkSmallGroups(b);
	status = od_LeaveOutSmallGroups(b);
	if (status != OD_OK)
	{
		return status;
	}
	od_ShareParticles(b);
	n = b->particleCount;
	b->centers = od_Alloc(sizeof(double) * 3 * (size_t)n);
	b->radii = od_Alloc(sizeof(double) * 3 * (size_t)n);
	b->axes = od_Alloc(sizeof(double) * 9 * (size_t)n);
	b->particleGroup = od_Alloc(sizeof(int) * (size_t)n);
	if (!b->centers || !b->radii || !b->axes || !b->particleGroup)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for %d particles", n);
	}
	for (int i = 0; i < b->groupCount; ++i)
	{
		for (int k = 0; k < b->groups[i].particles; ++k)
		{
			b->particleGroup[b->groups[i].first + k] = i;
		}
	}
	for (int i = 0; i < b->groupCount && status == OD_OK; ++i)
	{
		status = b->groups[i].particles > 0 ? od_BuildGroup(b, &b->groups[i]) : OD_OK;
	}
	status = status == OD_OK ? od_HostGroups(b) : status;
	status = status == OD_OK && b->def->joinPieces && b->groupCount > 1 ? od_JoinGroups(b) : status;
	if (status != OD_OK)
	{
		return status;
	}
	od_GraphDef def = od_DefaultGraphDef();
	def.particleCount = n;
	def.centers = b->centers;
	def.radii = b->radii;
	def.axes = b->axes;
	def.edgeCount = od_EdgeCount(b);
	def.edges = (const int*)b->edges.data;
	status = od_Graph_Create(&def, graph);
	status = status == OD_OK ? od_RecordPieces(b, *graph) : status;
	if (status != OD_OK)
	{
		od_Graph_Destroy(*graph);
		*graph = NULL;
	}
	return status;
}

od_Status od_Graph_CreateFromMesh(const od_MeshGraphDef* def, od_Graph** graph)
{
	*graph = NULL;
	od_Status status = od_CheckMeshGraphDef(def);
	if (status != OD_OK)
	{
		return status;
	}
	od_Builder b;
	memset(&b, 0, sizeof b);
	b.def = def;
	status = od_Build(&b, graph);
	for (int i = 0; i < b.groupCount; ++i)
	{
		od_Voxels_Destroy(&b.groups[i].voxels);
	}
	od_Free(b.groups);
	od_Free(b.groupTriangles);
	od_MeshPieces_Destroy(&b.pieces);
	od_Free(b.centers);
	od_Free(b.radii);
	od_Free(b.axes);
	od_Free(b.particleGroup);
	od_Free(b.groupOf);
	od_Free(b.edges.data);
	return status;
}
