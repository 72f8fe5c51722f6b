// Internal layout of an MPM world, shared by the mpm_*.c stages.
//
// Model (constant once set): the world definition, the material table, wind, collider shapes.
// State: particles (an array of od_MpmParticle, physically reordered by grid block every few substeps),
// per-particle output data kept in the order particles were added (rest and current orientation), the
// colliders' frames and the clock. Scratch: the sort buffers and the blocked grid, sized at warm-up.
//
// One substep: sort (grid.c) -> P2G (transfer.c) -> grid update with gravity, wind and colliders
// (world.c, wind.c, collider.c) -> G2P, which also updates F, applies the plasticity and
// computes the stress the next P2G scatters (material.c), the SVDs of F computed a batch of particles at a
// time (od_MpmSvdBatch) before the material uses them.
#pragma once

#include "opdeform/mpm.h"

#include "collider.h"
#include "field.h"
#include "math3.h"
#include "pool.h"

#include <stdint.h>

#define OD_MPM_BLOCK 4          // grid block edge, in nodes
#define OD_MPM_REGION 6         // nodes per axis that the particles of one block touch
#define OD_MPM_MAX_MATERIALS 16 // particle batches with their own material
#define OD_MPM_REORDER_EVERY 16 // substeps between physical reorderings of the particles

// Hot per-particle data: 256 bytes, what P2G and G2P read and write.
typedef struct od_MpmParticle
{
	double x[3], v[3];
	double C[9];   // APIC affine matrix (velocity gradient)
	double F[9];   // elastic deformation gradient
	double tau[6]; // Kirchhoff stress after the plasticity, xx yy zz xy xz yz (for the next P2G)
	double Jp;     // plastic volume change (snow)
	int32_t id;    // index in the order particles were added
	int32_t material;
} od_MpmParticle;

typedef struct od_MpmMaterialSlot
{
	od_MpmMaterial def;
	double volume, mass; // per particle
	double mu0, lambda0;
} od_MpmMaterialSlot;

typedef struct od_MpmCollider
{
	od_MpmContact contact;
	double friction;
	od_Collider body; // shape and frames (collide/collider.c)
} od_MpmCollider;

typedef struct od_MpmWind
{
	od_MpmWindDef def;
	int octaves;       // the octaves summed: def.octaves, less those the grid does not resolve (potential)
	double gain;       // potential: speed of its octaves matched to the noise wind's (1 for noise)
	uint8_t perm[512]; // Perlin permutation
} od_MpmWind;

// The blocked grid: a dense table from block coordinates to a slot in the node storage (or -1); only
// blocks that particles touch get a slot. A node holds (m vx, m vy, m vz, m), then (vx, vy, vz, m).
typedef struct od_MpmGrid
{
	int cells[3];  // cells per axis of the domain
	int blocks[3]; // blocks per axis
	int32_t* slotOfBlock;
	double* nodes; // capacity * 64 * 4
	int32_t* blockOfSlot;
	int slotCount, capacity;
} od_MpmGrid;

// Particles sorted by block for one substep: order[] holds particle indices; the occupied blocks (by
// colour for P2G) index ranges of it.
#define OD_MPM_INDEX_BITS 29 // particle index bits of a key; the 3 bits above say which +1 blocks it reaches
#define OD_MPM_MAX_PARTICLES (1 << OD_MPM_INDEX_BITS)

typedef struct od_MpmSort
{
	uint64_t* keys; // (block << 32 | reach << 29 | particle) and its radix buffer
	uint64_t* swap;
	int32_t* order;
	int32_t* occupiedBlock; // block index of each occupied block
	int32_t* occupiedStart; // count + 1 entries
	uint8_t* occupiedReach; // bit a: some particle of the block reaches the next block along axis a
	int occupiedCount;
	int32_t* byColour;      // occupied block numbers grouped by colour
	int colourStart[9];
} od_MpmSort;

// Particles whose deformation gradients get their SVDs together (od_Svd3Many: eight at a time where AVX2 runs),
// in G2P and in the orientation update, and the thread's room for them.
#define OD_MPM_SVD_BATCH 16
typedef struct od_MpmSvdBatch
{
	od_Mat3 F[OD_MPM_SVD_BATCH], U[OD_MPM_SVD_BATCH], V[OD_MPM_SVD_BATCH];
	od_Vec3 s[OD_MPM_SVD_BATCH];
} od_MpmSvdBatch;

// Per-thread reductions of G2P and scratch regions.
typedef struct od_MpmThreadData
{
	double region[OD_MPM_REGION * OD_MPM_REGION * OD_MPM_REGION * 4];
	od_MpmSvdBatch svd;
	double maxSpeed, maxHardening; // maxSpeed is infinite once a velocity is not finite
	char pad[64];
} od_MpmThreadData;

// Constant once set (particles add material slots, set_wind replaces the wind).
typedef struct od_MpmModel
{
	od_MpmWorldDef def;
	double invDx;
	od_MpmMaterialSlot materials[OD_MPM_MAX_MATERIALS];
	int materialCount;
	od_MpmWind wind;
	od_FieldSet fields; // force fields (force_fields.c)
} od_MpmModel;

// What a substep changes.
typedef struct od_MpmState
{
	od_MpmParticle* particles;
	int count, capacity;
	// by particle id: current orientation, quaternion of the last polar rotation
	double* quat;
	double* polarQuat;
	int sinceReorder;              // substeps since the particles were last moved into block order
	double maxSpeed, maxHardening; // of the last G2P, for the next substep's CFL bound
	od_MpmStats stats;
} od_MpmState;

struct od_MpmWorld
{
	od_MpmModel model;
	od_MpmState state;
	od_MpmCollider* colliders; // shapes (model) and their frames over the current call (state)
	int colliderCount;
	// scratch, sized at warm-up
	od_MpmParticle* spare; // reorder buffer
	od_MpmGrid grid;
	od_MpmSort sort;
	od_Pool* pool;
	od_MpmThreadData* threadData;
};

// world.c: grows every per-particle array (and the grid's block table, the sort buffers) to hold `capacity`
// particles; changes no particle.
od_Status od_MpmWorld_Reserve(od_MpmWorld* w, int capacity);

// grid.c
// Sizes the grid (refusing a domain of too many blocks); od_MpmGrid_Reserve allocates its block table.
od_Status od_MpmGrid_Init(od_MpmWorld* w);
od_Status od_MpmGrid_Reserve(od_MpmWorld* w);
void od_MpmGrid_Destroy(od_MpmGrid* g);
od_Status od_MpmSort_Reserve(od_MpmWorld* w, int capacity);
void od_MpmSort_Destroy(od_MpmSort* s);
// Sorts particles into blocks, reorders them physically when `reorder`, and gives every touched grid
// block a cleared slot.
od_Status od_MpmGrid_Prepare(od_MpmWorld* w, int reorder);
// Region of the occupied block `ob`: adds the thread's region into the grid, or loads the grid into it.
void od_MpmGrid_Flush(od_MpmWorld* w, int ob, double* region);
// Grid velocities from momenta, then gravity, wind, colliders and the domain's walls.
void od_MpmGrid_Update(od_MpmWorld* w, double dt);
void od_MpmGrid_Load(const od_MpmWorld* w, int ob, double* region);
// The region's first node (global node coordinates) of an occupied block.
void od_MpmGrid_RegionOrigin(const od_MpmWorld* w, int ob, int origin[3]);

// transfer.c
typedef struct od_MpmStencil
{
	int base[3];     // first node, global node coordinates
	double w[3][3];  // weights per axis
	double fx[3];    // (x - lower) / dx - base, in [0.5, 1.5)
} od_MpmStencil;
void od_MpmStencil_Make(const od_MpmWorld* w, const double x[3], od_MpmStencil* s);
void od_MpmP2G(od_MpmWorld* w, double dt);
void od_MpmG2P(od_MpmWorld* w, double dt);

// material.c
od_Status od_MpmMaterial_Check(const od_MpmMaterial* m);
void od_MpmMaterial_Derive(od_MpmMaterialSlot* slot);
// Plasticity projection of p->F (and p->Jp), then p->tau, from p->F = U diag(s) Vᵀ (od_Svd3); returns the
// hardening factor used.
double od_MpmMaterial_Update(const od_MpmMaterialSlot* slot, od_MpmParticle* p, const od_Mat3* U, od_Vec3 s,
							 const od_Mat3* V);
// Largest elastic wave speed at hardening factor h.
double od_MpmMaterial_WaveSpeed(const od_MpmMaterialSlot* slot, double h);

// wind.c
od_Status od_MpmWind_Set(od_MpmWind* wind, const od_MpmWindDef* def, double dx);
// The wind at (x, y, z) is od_MpmWind_At(od_MpmWind_Column(x, y, time), od_MpmWind_Height(z)): the noise
// depends on the horizontal position only and the height scaling κ on z only, so a block of nodes
// evaluates each once per column and per level.
void od_MpmWind_Column(const od_MpmWind* wind, double x, double y, double time, double column[2]);
double od_MpmWind_Height(const od_MpmWind* wind, double z);
od_Vec3 od_MpmWind_At(const od_MpmWind* wind, const double column[2], double kappa);
od_Vec3 od_MpmWind_Velocity(const od_MpmWind* wind, od_Vec3 x, double time);

// force_fields.c: a node's velocity v (gravity included) after the force fields over dt.
od_Vec3 od_MpmForceFields_Node(const od_MpmWorld* w, od_Vec3 x, od_Vec3 v, double dt);

// collider.c
od_Status od_MpmCollider_Init(od_MpmCollider* c, const od_MpmColliderDef* def, double dx);
void od_MpmCollider_Destroy(od_MpmCollider* c);
// Grid boundary condition on a node velocity at x; returns the velocity unchanged when x is outside.
od_Vec3 od_MpmCollider_Node(const od_MpmCollider* c, od_Vec3 x, od_Vec3 v);
// Pushes a particle that ended inside the collider back to its surface (position and velocity).
void od_MpmCollider_Particle(const od_MpmCollider* c, od_Vec3* x, od_Vec3* v);
// Contact response of a relative velocity against a surface normal.
od_Vec3 od_MpmContactResponse(od_MpmContact contact, double friction, od_Vec3 vrel, od_Vec3 n);

// rotation.c (and od_MpmWorld_UpdateOrientations)
void od_QuatFromMatrix(const od_Mat3* r, double q[4]);
od_Mat3 od_QuatToMatrix(const double q[4]);
