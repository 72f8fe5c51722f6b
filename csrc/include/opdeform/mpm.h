// opdeform MPM: tumbling particles (Song et al. 2022), the public C API.
//
// A world (od_MpmWorld) is a 3-D MLS-MPM simulation (APIC transfers, quadratic B-splines) on a blocked
// grid over a fixed domain box. Particles are added in batches that share a material; each particle
// also carries a rest orientation, and its current orientation is the rotation of the polar
// decomposition of its deformation gradient (scaled by the spin factor) applied to that rest
// orientation. Gravity, force fields, a Perlin-noise wind and colliders act on the grid.
//
// Arrays are row-major doubles in the order particles were added: positions and velocities n*3,
// quaternions n*4 as (w, x, y, z), matrices n*9 (M[3*r + c]). Every fallible call returns od_Status and
// leaves a message for od_GetErrorMessage(); a failed call changes nothing.
#pragma once

#if defined(OD_LAYER_CHECK) && !defined(OD_USES_MPM)
#error "opdeform/mpm.h is the mpm layer's header, which this layer of csrc/ may not use (docs/architecture.md)"
#endif

#include "opdeform/base.h"
#include "opdeform/fields.h"

#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

typedef struct od_MpmWorld od_MpmWorld;

typedef enum od_MpmMaterialKind
{
	OD_MPM_SNOW = 0,  // Stomakhin 2013: fixed-corotated elasticity, clamped singular values, hardening
	OD_MPM_JELLY = 1, // fixed-corotated elasticity, no plasticity
	OD_MPM_FLAKES = 2 // loose flakes: every shear is plastic and tension is released; resists compression only
} od_MpmMaterialKind;

typedef struct od_MpmMaterial
{
	od_MpmMaterialKind kind;
	double density;             // kg/m³
	double youngModulus;        // Pa
	double poissonRatio;        // in [0, 0.5)
	double criticalCompression; // θc (snow): singular values stay >= 1 - θc
	double criticalStretch;     // θs (snow): singular values stay <= 1 + θs
	double hardening;           // ξ (snow): μ, λ scale by exp(ξ (1 - Jp))
} od_MpmMaterial;

// The seed's Table 2: θc 2.5e-2, θs 4.5e-3, ξ 10, ρ 600, E 5e3, ν 0.3.
od_MpmMaterial od_MpmSnowMaterial(void);
od_MpmMaterial od_MpmJellyMaterial(void);
od_MpmMaterial od_MpmFlakeMaterial(void);

typedef enum od_MpmContact
{
	OD_MPM_STICKY = 0,  // the material moves with the collider
	OD_MPM_SLIP = 1,    // the normal relative velocity is removed, the tangential one kept (less friction)
	OD_MPM_SEPARATE = 2 // like slip, but only while approaching: material may leave the surface
} od_MpmContact;

typedef struct od_MpmWorldDef
{
	double lower[3], upper[3]; // the domain box; particles must stay inside it
	double dx;                 // grid spacing
	double gravity[3];
	double cfl;                // a substep moves material at most this fraction of a cell (velocity and wave speed)
	double maxDt;              // upper bound of a substep
	double spin;               // η: the particle's rotation angle is scaled by it; 0 = plain MLS-MPM (no turning)
	od_MpmContact walls;       // behaviour of the domain's faces
	double wallFriction;
	int threads;               // 0..64; 0 = the CPUs this process may use (affinity, at most OMP_NUM_THREADS)
} od_MpmWorldDef;

od_MpmWorldDef od_DefaultMpmWorldDef(void);

typedef struct od_MpmParticlesDef
{
	int count;
	const double* positions;    // count*3, inside the domain (at least two cells from its faces)
	const double* velocities;   // count*3 or NULL (zero)
	const double* affine;       // count*9 APIC matrices C (velocity gradients) or NULL (zero)
	const double* orientations; // count*4 rest orientations (unit quaternions w,x,y,z) or NULL (identity)
	double particleVolume;      // m³ per particle (mass = density * volume)
	od_MpmMaterial material;
} od_MpmParticlesDef;

od_MpmParticlesDef od_DefaultMpmParticlesDef(void);

typedef enum od_MpmWindKind
{
	OD_MPM_WIND_OFF = 0,
	OD_MPM_WIND_NOISE = 1,    // two independent 2-D Perlin noise channels for x and y: a flow with vorticity
	OD_MPM_WIND_POTENTIAL = 2 // the horizontal gradient of 2-D Perlin noise, no height scaling: curl-free
} od_MpmWindKind;

typedef struct od_MpmWindDef
{
	od_MpmWindKind kind;
	double velocity[3];  // mean wind
	double amplitude;    // m/s of the noise part
	double wavelength;   // m, of the first octave
	int octaves;
	double persistence;  // amplitude factor from one octave to the next
	double drift[2];     // m/s: the noise pattern moves with this velocity
	double drag;         // 1/s: grid velocities relax towards the wind at this rate
	double ground;       // height scaling κ(z) = ((z - ground) / refHeight)^exponent, 0 below ground
	double refHeight;
	double exponent;     // 0: no height scaling
	unsigned seed;
} od_MpmWindDef;

od_MpmWindDef od_DefaultMpmWindDef(void);

typedef enum od_MpmShape
{
	OD_MPM_PLANE = 0,  // the half space z < 0 of the collider's frame (a floor when unrotated)
	OD_MPM_BOX = 1,    // |x|, |y|, |z| <= halfExtents in the collider's frame
	OD_MPM_SPHERE = 2, // radius halfExtents[0]
	OD_MPM_MESH = 3    // a closed triangle mesh in the collider's frame
} od_MpmShape;

typedef struct od_MpmColliderDef
{
	od_MpmShape shape;
	od_MpmContact contact;
	double friction;       // Coulomb coefficient of the tangential relative velocity
	double halfExtents[3];
	int vertexCount;
	const double* vertices; // vertexCount*3 (mesh)
	int triangleCount;
	const int* triangles;   // triangleCount*3 (mesh)
	double rotation[9];     // the collider's frame in the world
	double translation[3];
} od_MpmColliderDef;

od_MpmColliderDef od_DefaultMpmColliderDef(void);

typedef struct od_MpmStats
{
	long long substeps;  // since creation
	int lastSubsteps;    // in the last od_MpmWorld_Step
	double time;         // simulated seconds
	double lastDt;
	int activeBlocks;    // grid blocks (4³ nodes) touched by the last substep
	double maxSpeed;     // of the particles after the last substep
} od_MpmStats;

typedef enum od_MpmField
{
	OD_MPM_POSITIONS = 0,    // n*3
	OD_MPM_VELOCITIES = 1,   // n*3
	OD_MPM_ORIENTATIONS = 2, // n*4: exp(η log R) applied to the rest orientation; sign continuous over frames
	OD_MPM_ROTATIONS = 3,    // n*9: R = U Vᵀ of the deformation gradient's SVD (as of the last orientation update)
	OD_MPM_DEFORMATION = 4,  // n*9: the elastic deformation gradient F
	OD_MPM_AFFINE = 5,       // n*9: the APIC matrix C
	OD_MPM_PLASTIC_J = 6     // n: Jp, the plastic volume change (snow)
} od_MpmField;

od_Status od_MpmWorld_Create(const od_MpmWorldDef* def, od_MpmWorld** world);
void od_MpmWorld_Destroy(od_MpmWorld* world);
od_MpmWorldDef od_MpmWorld_GetDef(const od_MpmWorld* world);
// Polls the interrupt handler every 4,096 particles: on OD_ERROR_INTERRUPTED (as on any failure) nothing
// was added.
od_Status od_MpmWorld_AddParticles(od_MpmWorld* world, const od_MpmParticlesDef* def);
int od_MpmWorld_GetParticleCount(const od_MpmWorld* world);
od_Status od_MpmWorld_SetWind(od_MpmWorld* world, const od_MpmWindDef* def);
od_Status od_MpmWorld_AddCollider(od_MpmWorld* world, const od_MpmColliderDef* def, int* id);
// The collider's frame at the end of the next Step or Substep; it moves there linearly (rotation along
// the shortest arc) over that call, and the grid sees its velocity.
od_Status od_MpmWorld_MoveCollider(od_MpmWorld* world, int id, const double rotation[9], const double translation[3]);
// The world's force fields (opdeform/fields.h, the ARAP solver's kinds): they act on the grid velocities
// after gravity, besides the noise wind of od_MpmWorld_SetWind.
od_FieldSet* od_MpmWorld_GetForceFields(od_MpmWorld* world);

// Advances `duration` seconds in substeps chosen by the CFL condition, then updates the orientations.
// OD_ERROR_ARGUMENT, with nothing moved, when the duration would take more than 100,000 substeps (and if
// the material speeds up past that mid-call, the world stays valid at the time reached). OD_ERROR_NOT_FINITE
// when a substep produced a non-finite state: the world's state is then unusable; create a new world.
od_Status od_MpmWorld_Step(od_MpmWorld* world, double duration);
// One substep of exactly dt (no CFL); orientations are not updated.
od_Status od_MpmWorld_Substep(od_MpmWorld* world, double dt);
// Recomputes orientations and rotations from the current deformation gradients. Polls the interrupt handler
// (od_SetInterruptHandler) every 65,536 particles: on OD_ERROR_INTERRUPTED nothing changed (Step then keeps
// the state of its last substep, as when stopped between substeps).
od_Status od_MpmWorld_UpdateOrientations(od_MpmWorld* world);

// Copies a field into out (the sizes of od_MpmField), particles in the order they were added.
void od_MpmWorld_Read(const od_MpmWorld* world, od_MpmField field, double* out);
int od_MpmFieldWidth(od_MpmField field);
od_MpmStats od_MpmWorld_GetStats(const od_MpmWorld* world);

// The state (particles, orientations, clock, collider frames) as bytes of this build, for a checkpoint:
// LoadState on a world made by the same calls (create, wind, colliders; particles are replaced) continues to
// the same bits. SaveState writes StateSize bytes, polling the interrupt handler every 4 MiB (on
// OD_ERROR_INTERRUPTED the bytes are incomplete; the world is only read). LoadState checks every count, id, index and number before it
// writes anything (the bytes may come from a damaged or crafted file): OD_ERROR_ARGUMENT naming the first
// problem, the world unchanged.
size_t od_MpmWorld_StateSize(const od_MpmWorld* world);
od_Status od_MpmWorld_SaveState(const od_MpmWorld* world, void* out);
od_Status od_MpmWorld_LoadState(od_MpmWorld* world, const void* in, size_t size);

#ifdef __cplusplus
}
#endif
