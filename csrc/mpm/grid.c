// The blocked grid of the MPM world and the sorting of particles into its blocks.
//
// Design: the domain is cut into blocks of 4³ nodes. A particle belongs to the block of its stencil's
// first node, so the 3³ nodes it touches lie in a 6³ region starting there, spread over that block and its
// +1 neighbours along each axis. Every substep the particles are sorted by block (an LSD radix sort of
// (block, particle) keys, independent of the domain's size), the occupied blocks are listed and grouped
// by the parity of their coordinates (8 colours: blocks of one colour never share a region node, so one
// colour's regions can be added to the grid in parallel and deterministically), and only the blocks that
// regions reach get node storage, from a pool that grows at warm-up only. The particles themselves are
// moved into sorted order every OD_MPM_REORDER_EVERY substeps; in between they are visited through the
// sorted index, which stays nearly sequential because particles move less than a cell per substep.
#include "world.h"

#include "core.h"

#include <string.h>

#define OD_NODE_DOUBLES 4
#define OD_BLOCK_NODES (OD_MPM_BLOCK * OD_MPM_BLOCK * OD_MPM_BLOCK)
#define OD_BLOCK_DOUBLES (OD_BLOCK_NODES * OD_NODE_DOUBLES)

od_Status od_MpmGrid_Init(od_MpmWorld* w)
{
	od_MpmGrid* g = &w->grid;
	size_t total = 1;
	for (int a = 0; a < 3; ++a)
	{
		double cells = ceil((w->model.def.upper[a] - w->model.def.lower[a]) * w->model.invDx - 1e-9);
		if (!(cells <= (double)(1 << 30))) // before the cast: a larger double does not fit an int
		{
			return od_Fail(OD_ERROR_ARGUMENT, "world: the domain spans %g cells on an axis, more than 2^30: increase dx",
						   cells);
		}
		g->cells[a] = (int)cells;
		g->blocks[a] = g->cells[a] / OD_MPM_BLOCK + 2;
		total *= (size_t)g->blocks[a];
	}
	if (total > ((size_t)1 << 30))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "world: the domain has %zu grid blocks, more than 2^30: increase dx",
					   total);
	}
	return OD_OK;
}

// The block table is 4 bytes a block of the whole domain (1.86 GB for a 1 m box at dx = 0.32 mm), so it is
// made with the first particles: a world that never gets any, or whose first batch is refused, costs nothing.
od_Status od_MpmGrid_Reserve(od_MpmWorld* w)
{
	od_MpmGrid* g = &w->grid;
	if (g->slotOfBlock)
	{
		return OD_OK;
	}
	size_t total = (size_t)g->blocks[0] * (size_t)g->blocks[1] * (size_t)g->blocks[2];
	g->slotOfBlock = od_Alloc(total * sizeof(int32_t));
	if (!g->slotOfBlock)
	{
		return od_Fail(OD_ERROR_MEMORY, "world: out of memory for the block table (%zu blocks)", total);
	}
	memset(g->slotOfBlock, 0xff, total * sizeof(int32_t));
	return OD_OK;
}

void od_MpmGrid_Destroy(od_MpmGrid* g)
{
	od_Free(g->slotOfBlock);
	od_Free(g->nodes);
	od_Free(g->blockOfSlot);
}

od_Status od_MpmSort_Reserve(od_MpmWorld* w, int capacity)
{
	od_MpmSort* s = &w->sort;
	size_t n = (size_t)capacity;
	uint64_t* keys = od_Realloc(s->keys, n * sizeof *keys);
	s->keys = keys ? keys : s->keys;
	uint64_t* swap = od_Realloc(s->swap, n * sizeof *swap);
	s->swap = swap ? swap : s->swap;
	int32_t* order = od_Realloc(s->order, n * sizeof *order);
	s->order = order ? order : s->order;
	int32_t* ob = od_Realloc(s->occupiedBlock, n * sizeof *ob);
	s->occupiedBlock = ob ? ob : s->occupiedBlock;
	int32_t* os = od_Realloc(s->occupiedStart, (n + 1) * sizeof *os);
	s->occupiedStart = os ? os : s->occupiedStart;
	int32_t* bc = od_Realloc(s->byColour, n * sizeof *bc);
	s->byColour = bc ? bc : s->byColour;
	uint8_t* reach = od_Realloc(s->occupiedReach, n);
	s->occupiedReach = reach ? reach : s->occupiedReach;
	if (!keys || !swap || !order || !ob || !os || !bc || !reach)
	{
		return od_Fail(OD_ERROR_MEMORY, "world: out of memory for %d particles", capacity);
	}
	return OD_OK;
}

void od_MpmSort_Destroy(od_MpmSort* s)
{
	od_Free(s->keys);
	od_Free(s->swap);
	od_Free(s->order);
	od_Free(s->occupiedBlock);
	od_Free(s->occupiedStart);
	od_Free(s->byColour);
	od_Free(s->occupiedReach);
}

static void od_BlockCoords(const od_MpmGrid* g, int32_t block, int b[3])
{
	b[0] = block % g->blocks[0];
	b[1] = (block / g->blocks[0]) % g->blocks[1];
	b[2] = block / (g->blocks[0] * g->blocks[1]);
}

// The key of particle i: its block, and which +1 neighbours its stencil reaches (local base >= 2).
static uint64_t od_Key(const od_MpmWorld* w, int i)
{
	int b[3];
	unsigned reach = 0;
	for (int a = 0; a < 3; ++a)
	{
		int base = (int)floor((w->state.particles[i].x[a] - w->model.def.lower[a]) * w->model.invDx - 0.5);
		b[a] = base / OD_MPM_BLOCK;
		reach |= (unsigned)(base % OD_MPM_BLOCK >= 2) << a;
	}
	uint64_t block = (uint64_t)(b[0] + w->grid.blocks[0] * (b[1] + w->grid.blocks[1] * b[2]));
	return block << 32 | (uint64_t)reach << OD_MPM_INDEX_BITS | (uint32_t)i;
}

static int32_t od_KeyIndex(uint64_t key)
{
	return (int32_t)(key & (OD_MPM_MAX_PARTICLES - 1));
}

static uint8_t od_KeyReach(uint64_t key)
{
	return (uint8_t)((key >> OD_MPM_INDEX_BITS) & 7);
}

#define OD_KEY_TASKS 64
// The pool's measures of work, nanoseconds on one thread (docs/speed.md): a particle's key, a block's clearing
// and update.
#define OD_KEY_NS 60.0
#define OD_CLEAR_NS 250.0
#define OD_UPDATE_NS 200.0 // without wind (with it: 3,400)

static void od_KeyTask(void* ctx, int task, int thread)
{
	(void)thread;
	od_MpmWorld* w = ctx;
	int begin, end;
	od_TaskRange(w->state.count, OD_KEY_TASKS, task, &begin, &end);
	for (int i = begin; i < end; ++i)
	{
		w->sort.keys[i] = od_Key(w, i);
	}
}

// Stable LSD radix sort of the keys by their block part, 8 bits a pass.
static void od_RadixSort(od_MpmWorld* w)
{
	const od_MpmGrid* g = &w->grid;
	uint64_t maxBlock = (uint64_t)g->blocks[0] * g->blocks[1] * g->blocks[2];
	uint64_t *src = w->sort.keys, *dst = w->sort.swap;
	for (int shift = 32; (maxBlock >> (shift - 32)) > 0; shift += 8)
	{
		int count[257] = { 0 };
		for (int i = 0; i < w->state.count; ++i)
		{
			count[((src[i] >> shift) & 255) + 1]++;
		}
		for (int d = 0; d < 256; ++d)
		{
			count[d + 1] += count[d];
		}
		for (int i = 0; i < w->state.count; ++i)
		{
			dst[count[(src[i] >> shift) & 255]++] = src[i];
		}
		uint64_t* t = src;
		src = dst;
		dst = t;
	}
	w->sort.keys = src;
	w->sort.swap = dst;
}

// Moves the particles into sorted order (the keys then name the new places).
static void od_Reorder(od_MpmWorld* w)
{
	for (int k = 0; k < w->state.count; ++k)
	{
		w->spare[k] = w->state.particles[od_KeyIndex(w->sort.keys[k])];
		w->sort.keys[k] = (w->sort.keys[k] & ~(uint64_t)(OD_MPM_MAX_PARTICLES - 1)) | (uint32_t)k;
	}
	od_MpmParticle* t = w->state.particles;
	w->state.particles = w->spare;
	w->spare = t;
}

// A slot (cleared later) for every block that a region of an occupied block reaches.
static od_Status od_AssignSlots(od_MpmWorld* w)
{
	od_MpmGrid* g = &w->grid;
	for (int s = 0; s < g->slotCount; ++s)
	{
		g->slotOfBlock[g->blockOfSlot[s]] = -1;
	}
	g->slotCount = 0;
	for (int ob = 0; ob < w->sort.occupiedCount; ++ob)
	{
		int b[3];
		od_BlockCoords(g, w->sort.occupiedBlock[ob], b);
		for (int n = 0; n < 8; ++n)
		{
			int32_t block = (b[0] + (n & 1)) + g->blocks[0] * ((b[1] + ((n >> 1) & 1)) + g->blocks[1] * (b[2] + (n >> 2)));
			if ((n & w->sort.occupiedReach[ob]) != n || g->slotOfBlock[block] >= 0)
			{
				continue;
			}
			if (g->slotCount == g->capacity)
			{
				int capacity = g->capacity + g->capacity / 2 + 64;
				double* nodes = od_Realloc(g->nodes, (size_t)capacity * OD_BLOCK_DOUBLES * sizeof(double));
				g->nodes = nodes ? nodes : g->nodes;
				int32_t* owners = od_Realloc(g->blockOfSlot, (size_t)capacity * sizeof(int32_t));
				g->blockOfSlot = owners ? owners : g->blockOfSlot;
				if (!nodes || !owners)
				{
					return od_Fail(OD_ERROR_MEMORY, "world: out of memory for %d grid blocks", capacity);
				}
				g->capacity = capacity;
			}
			g->slotOfBlock[block] = g->slotCount;
			g->blockOfSlot[g->slotCount++] = block;
		}
	}
	return OD_OK;
}

static void od_ClearTask(void* ctx, int task, int thread)
{
	(void)thread;
	od_MpmGrid* g = ctx;
	memset(g->nodes + (size_t)task * OD_BLOCK_DOUBLES, 0, OD_BLOCK_DOUBLES * sizeof(double));
}

od_Status od_MpmGrid_Prepare(od_MpmWorld* w, int reorder)
{
	od_MpmSort* s = &w->sort;
	od_Pool_Run(w->pool, OD_KEY_TASKS, OD_KEY_NS * w->state.count, od_KeyTask, w);
	od_RadixSort(w);
	if (reorder)
	{
		od_Reorder(w);
	}
	s->occupiedCount = 0;
	int colourCount[8] = { 0 };
	for (int k = 0; k < w->state.count; ++k)
	{
		s->order[k] = od_KeyIndex(s->keys[k]);
		int32_t block = (int32_t)(s->keys[k] >> 32);
		if (k == 0 || block != s->occupiedBlock[s->occupiedCount - 1])
		{
			int b[3];
			od_BlockCoords(&w->grid, block, b);
			colourCount[(b[0] & 1) | (b[1] & 1) << 1 | (b[2] & 1) << 2]++;
			s->occupiedReach[s->occupiedCount] = 0;
			s->occupiedBlock[s->occupiedCount] = block;
			s->occupiedStart[s->occupiedCount++] = k;
		}
		s->occupiedReach[s->occupiedCount - 1] |= od_KeyReach(s->keys[k]);
	}
	s->occupiedStart[s->occupiedCount] = w->state.count;
	s->colourStart[0] = 0;
	for (int c = 0; c < 8; ++c)
	{
		s->colourStart[c + 1] = s->colourStart[c] + colourCount[c];
		colourCount[c] = s->colourStart[c];
	}
	for (int ob = 0; ob < s->occupiedCount; ++ob)
	{
		int b[3];
		od_BlockCoords(&w->grid, s->occupiedBlock[ob], b);
		s->byColour[colourCount[(b[0] & 1) | (b[1] & 1) << 1 | (b[2] & 1) << 2]++] = ob;
	}
	od_Status status = od_AssignSlots(w);
	if (status == OD_OK)
	{
		od_Pool_Run(w->pool, w->grid.slotCount, OD_CLEAR_NS * w->grid.slotCount, od_ClearTask, &w->grid);
	}
	return status;
}

void od_MpmGrid_RegionOrigin(const od_MpmWorld* w, int ob, int origin[3])
{
	od_BlockCoords(&w->grid, w->sort.occupiedBlock[ob], origin);
	for (int a = 0; a < 3; ++a)
	{
		origin[a] *= OD_MPM_BLOCK;
	}
}

// Walks the region of an occupied block block by block: adds it into the grid (load = 0) or copies the
// grid into it (load = 1). Region layout: [z][y][x][4] with OD_MPM_REGION nodes per axis.
static void od_RegionTransfer(const od_MpmWorld* w, int ob, double* region, int load)
{
	const od_MpmGrid* g = &w->grid;
	int b[3];
	od_BlockCoords(g, w->sort.occupiedBlock[ob], b);
	for (int n = 0; n < 8; ++n)
	{
		if ((n & w->sort.occupiedReach[ob]) != n)
		{
			continue; // no particle of the block reaches this neighbour: its part of the region is zero
		}
		int o[3] = { n & 1, (n >> 1) & 1, n >> 2 };
		int32_t block = (b[0] + o[0]) + g->blocks[0] * ((b[1] + o[1]) + g->blocks[1] * (b[2] + o[2]));
		double* nodes = g->nodes + (size_t)g->slotOfBlock[block] * OD_BLOCK_DOUBLES;
		// region coordinates covered by this block: [0, 4) for o = 0, [4, 6) for o = 1
		int lo[3], hi[3];
		for (int a = 0; a < 3; ++a)
		{
			lo[a] = o[a] * OD_MPM_BLOCK;
			hi[a] = o[a] ? OD_MPM_REGION : OD_MPM_BLOCK;
		}
		for (int z = lo[2]; z < hi[2]; ++z)
		{
			for (int y = lo[1]; y < hi[1]; ++y)
			{
				for (int x = lo[0]; x < hi[0]; ++x)
				{
					double* r = region + (((z * OD_MPM_REGION) + y) * OD_MPM_REGION + x) * OD_NODE_DOUBLES;
					double* node = nodes + ((((z & 3) * OD_MPM_BLOCK) + (y & 3)) * OD_MPM_BLOCK + (x & 3)) *
											   OD_NODE_DOUBLES;
					for (int k = 0; k < OD_NODE_DOUBLES; ++k)
					{
						if (load)
						{
							r[k] = node[k];
						}
						else
						{
							node[k] += r[k];
						}
					}
				}
			}
		}
	}
}

void od_MpmGrid_Flush(od_MpmWorld* w, int ob, double* region)
{
	od_RegionTransfer(w, ob, region, 0);
}

void od_MpmGrid_Load(const od_MpmWorld* w, int ob, double* region)
{
	od_RegionTransfer(w, ob, region, 1);
}

typedef struct od_UpdateJob
{
	od_MpmWorld* w;
	double dt, time, windBlend;
} od_UpdateJob;

// The domain's faces act on nodes within 3 of them (the stencil of a particle clamped one cell inside).
static od_Vec3 od_Walls(const od_MpmWorld* w, const int node[3], od_Vec3 v)
{
	for (int a = 0; a < 3; ++a)
	{
		int side = node[a] < 3 ? 1 : (node[a] > w->grid.cells[a] - 3 ? -1 : 0);
		if (side != 0)
		{
			double n[3] = { 0, 0, 0 };
			n[a] = side;
			v = od_MpmContactResponse(w->model.def.walls, w->model.def.wallFriction, v, od_V3Load(n));
		}
	}
	return v;
}

static void od_UpdateTask(void* ctx, int task, int thread)
{
	(void)thread;
	const od_UpdateJob* job = ctx;
	od_MpmWorld* w = job->w;
	int b[3];
	od_BlockCoords(&w->grid, w->grid.blockOfSlot[task], b);
	double* nodes = w->grid.nodes + (size_t)task * OD_BLOCK_DOUBLES;
	od_Vec3 gravity = od_V3Load(w->model.def.gravity);
	double columns[OD_MPM_BLOCK * OD_MPM_BLOCK][2], kappa[OD_MPM_BLOCK];
	unsigned done = 0; // bits 0-15: columns whose wind is in `columns`; bits 16-19: levels in `kappa`
	for (int i = 0; i < OD_BLOCK_NODES; ++i)
	{
		double* node = nodes + i * OD_NODE_DOUBLES;
		if (node[3] <= 0.0)
		{
			continue;
		}
		int g[3] = { b[0] * OD_MPM_BLOCK + (i & 3), b[1] * OD_MPM_BLOCK + ((i >> 2) & 3), b[2] * OD_MPM_BLOCK + (i >> 4) };
		od_Vec3 x = od_V3(w->model.def.lower[0] + g[0] / w->model.invDx, w->model.def.lower[1] + g[1] / w->model.invDx,
						  w->model.def.lower[2] + g[2] / w->model.invDx);
		od_Vec3 v = od_MulAdd(od_Scale(1.0 / node[3], od_V3Load(node)), job->dt, gravity);
		v = w->model.fields.count ? od_MpmForceFields_Node(w, x, v, job->dt) : v;
		if (job->windBlend > 0.0)
		{
			int column = i & 15, level = i >> 4;
			if (!(done >> column & 1))
			{
				od_MpmWind_Column(&w->model.wind, x.x, x.y, job->time, columns[column]);
				done |= 1u << column;
			}
			if (!(done >> (16 + level) & 1))
			{
				kappa[level] = od_MpmWind_Height(&w->model.wind, x.z);
				done |= 1u << (16 + level);
			}
			od_Vec3 wind = od_MpmWind_At(&w->model.wind, columns[column], kappa[level]);
			v = od_MulAdd(v, job->windBlend, od_Sub(wind, v));
		}
		for (int c = 0; c < w->colliderCount; ++c)
		{
			v = od_MpmCollider_Node(&w->colliders[c], x, v);
		}
		od_V3Store(node, od_Walls(w, g, v));
	}
}

void od_MpmGrid_Update(od_MpmWorld* w, double dt)
{
	od_UpdateJob job = { w, dt, w->state.stats.time + dt,
						 w->model.wind.def.kind == OD_MPM_WIND_OFF ? 0.0 : 1.0 - exp(-w->model.wind.def.drag * dt) };
	od_Pool_Run(w->pool, w->grid.slotCount, OD_UPDATE_NS * w->grid.slotCount, od_UpdateTask, &job);
}
