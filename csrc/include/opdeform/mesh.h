// opdeform: triangle meshes and oriented-particle graphs, the public C API.
//
// - od_Graph_CreateFromMesh builds a graph whose ellipsoids cover a mesh (METHOD.md, "Building a graph
//   from a mesh"): through the volume of closed pieces, along the surface (or the length) of open or thin
//   ones, or as a 1-D chain along the principal axis.
// - od_Skin binds a rest mesh to a graph once (Sumner weights over the m nearest particles) and then maps
//   a simulation state to deformed vertex positions and, on request, normals (eq. 1), into float32 or
//   float64 buffers, on every core.
// - od_Mesh_Parse* / od_Mesh_Format* read and write OBJ and PLY from and to memory (no file access here).
// Vertices are row-major doubles (V*3), triangles row-major ints (T*3), as in numpy (V,3) and (T,3).
#pragma once

#if defined(OD_LAYER_CHECK) && !defined(OD_USES_MESH)
#error "opdeform/mesh.h is the mesh layer's header, which this layer of csrc/ may not use (docs/architecture.md)"
#endif

#include "opdeform/graph.h"

#include <stdbool.h>
#include <stddef.h>

#ifdef __cplusplus
extern "C" {
#endif

// ---------------------------------------------------------------------------------------------------------
// Graph from a mesh

typedef enum od_MeshGraphMode
{
	OD_MESH_AUTO,    // per piece: closed pieces as OD_MESH_VOLUME, open ones as OD_MESH_SURFACE
	OD_MESH_VOLUME,  // particles through what the surface encloses (holes smaller than a voxel are bridged)
	OD_MESH_SURFACE, // particles along the surface only (a hollow shell)
	OD_MESH_CHAIN,   // per piece a 1-D chain of particles along its principal axis (the paper's bar)
} od_MeshGraphMode;

// What becomes of a small piece of the mesh (an eye, a tooth, a button): one whose voxels are fewer than
// OD_SMALL_PIECE_RATIO of the largest piece's (a share of the mesh, so the same at any scale and any
// particle count). Pieces of no area (degenerate triangles only: a point or a line) are never small.
// Attaching gives no particles rather than particles joined by edges (which is OD_SMALL_OWN): the piece
// costs none of the budget (thirty teeth would take 120 particles of 4 each) and moves by one affine map,
// which is what rigid means; on Suzanne dropped (tests/test_loose_parts.py) both keep the eyes in their
// sockets (off by 0.03 % and 2.6 % of the head's size at 100 and 1,000 particles attached, 0.03 % and
// 0.8 % with their own particles), where before this the eyes tore off (22 % and 28 %, edges 191x, 283x).
typedef enum od_SmallPieces
{
	OD_SMALL_ATTACH, // no particles: skinned rigidly by the particles of the large piece nearest to it
	OD_SMALL_OWN,    // particles of its own, joined by edges to that piece: at least OD_SMALL_PIECE_PARTICLES
	                 // from the budget when compact or open (a shell with a boundary); when closed and long or
	                 // flat, its share of the budget and particles added beyond it up to OD_SHELL_PARTICLES
	                 // where fewer (never more than its voxels); the compact and open ones' particles from the
	                 // budget together at most OD_SMALL_PIECE_SHARE of it, largest first, the next ones theirs
	                 // added beyond the budget, at most OD_SMALL_PIECE_EXTRA of it, the others attached
} od_SmallPieces;

#define OD_SMALL_PIECE_RATIO 0.1
#define OD_SMALL_PIECE_PARTICLES 4
#define OD_SMALL_PIECE_SHARE 0.5 // of the budget, at most, to small pieces' OD_SMALL_PIECE_PARTICLES each
#define OD_SMALL_PIECE_EXTRA 0.5 // ... and at most this share of it again added beyond it for those past that
#define OD_SHELL_PARTICLES 16
#define OD_LONG_SHELL 0.4 // longest side^2 / area (an open piece's counted twice) above which a small piece is long or
                          // flat (a sphere: 1/pi)
#define OD_BEAM_SHELL 1.5 // a long piece whose particles spread this much more along one axis than the next (the
                          // dog's ears 1.75-1.82, tails and trunks 4.6-6.5, ellie's ear plates 1.06)
#define OD_ROOT_LINKS 3   // ... is linked to its host from this many particles, those nearest it (3 hold a frame)
#define OD_CARD_REACH 0.5 // an open small piece reaching this share of its longest side out of every large piece's
                          // bounding box is a card (the outside bird's wings and cards 0.8-1.0; gob's Skin patches
                          // in 5.2 0.06 at most)

typedef struct od_MeshGraphDef
{
	int vertexCount;
	const double* vertices; // vertexCount*3, finite
	int triangleCount;
	const int* triangles;   // triangleCount*3, indices in [0, vertexCount)
	int particleCount;      // how many particles the graph gets (100), and with OD_SMALL_OWN those added to
	                        // raise long small pieces to OD_SHELL_PARTICLES
	od_MeshGraphMode mode;  // OD_MESH_AUTO
	bool joinPieces;        // false: each connected piece of the mesh gets its own connected graph; true: one
	                        // graph (pieces whose boxes overlap are one solid, others get joining edges)
	int voxelsPerParticle;  // resolution of the voxelization that the particles are fitted to (100)
	od_SmallPieces smallPieces; // OD_SMALL_ATTACH
} od_MeshGraphDef;

od_MeshGraphDef od_DefaultMeshGraphDef(void);
// Polls the interrupt handler (od_SetInterruptHandler) while voxelizing and growing cells: on
// OD_ERROR_INTERRUPTED no graph is made.
od_Status od_Graph_CreateFromMesh(const od_MeshGraphDef* def, od_Graph** graph);

// ---------------------------------------------------------------------------------------------------------
// Skinning

typedef struct od_Skin od_Skin;

typedef struct od_SkinDef
{
	int vertexCount;
	const double* vertices; // vertexCount*3 rest positions, finite
	int triangleCount;      // optional: rest normals are then the area-weighted normals of the triangles
	const int* triangles;
	const double* normals;  // optional rest normals (vertexCount*3); used instead of the triangles' ones
	int neighbors;          // m (4); fewer when the graph has fewer particles
	int threadCount;        // 0..64; 0 = the CPUs this process may use (affinity, OMP_NUM_THREADS); meshes of fewer than 16384 vertices use one
} od_SkinDef;

od_SkinDef od_DefaultSkinDef(void);
// Binds once; the skin copies what it needs of the graph and may outlive it. Polls the interrupt handler
// (od_SetInterruptHandler) between batches of vertices: on OD_ERROR_INTERRUPTED no skin is made.
od_Status od_Skin_Create(const od_Graph* graph, const od_SkinDef* def, od_Skin** skin);
void od_Skin_Destroy(od_Skin* skin);
int od_Skin_GetVertexCount(const od_Skin* skin);
int od_Skin_GetParticleCount(const od_Skin* skin);
int od_Skin_GetNeighborCount(const od_Skin* skin); // row width: m, or half as many again with an open sheet piece
// vertexCount*m, nearest first, from the vertex's own mesh piece (as od_Graph_SkinWeights); a row of a
// vertex whose piece has fewer than m particles ends with weight-0 repeats of its nearest particle.
const int* od_Skin_GetIndices(const od_Skin* skin);
const double* od_Skin_GetWeights(const od_Skin* skin); // vertexCount*m, each row sums to 1
const double* od_Skin_GetRestNormals(const od_Skin* skin); // vertexCount*3, NULL when none were given

typedef enum od_Scalar
{
	OD_FLOAT64,
	OD_FLOAT32,
} od_Scalar;

// Where od_Skin_Deform writes. Buffers are vertexCount*3 (the flat layout of Blender's foreach_set).
typedef struct od_SkinTarget
{
	void* positions;        // required
	od_Scalar positionType;
	void* normals;          // NULL: no normals are computed
	od_Scalar normalType;
	const void* restNormals; // NULL: the skin's own rest normals
	od_Scalar restNormalType;
} od_SkinTarget;

// p = Σ wj [Rj (p̄ − X̄j) + xj] and n = normalize(Σ wj Rj n̄) for every vertex, from particle positions
// (n*3) and rotations (n*9). Not from two threads at once on one skin (it runs on the skin's threads).
od_Status od_Skin_Deform(const od_Skin* skin, const double* positions, const double* rotations,
						 const od_SkinTarget* target);

// What a frame shows of a skinned mesh over its animated input, in one pass over count vertices (count*3 values):
// offset = float32((skinned - reference) * lock) and out = input + offset, added in float32 (lock NULL: 1). The
// same operations, one per value, as numpy's np.subtract, *=, a float32 cast and np.add, so the same bits.
void od_ShownOffset(int count, const double* skinned, const double* reference, const double* lock,
					const float* input, float* offset, float* out);

// od_ShownOffset whose reference is the skin of particle positions (n*3) and rotations (n*9), made in the same pass
// block by block and never stored: the same bits as od_Skin_Deform into a float64 buffer, then od_ShownOffset.
// Not from two threads at once on one skin (as od_Skin_Deform).
od_Status od_Skin_DeformShown(const od_Skin* skin, const double* positions, const double* rotations,
							  const double* skinned, const double* lock, const float* input, float* offset,
							  float* out);

// ---------------------------------------------------------------------------------------------------------
// OBJ and PLY

typedef struct od_Mesh
{
	int vertexCount;
	double* vertices;
	int triangleCount;
	int* triangles;
} od_Mesh;

// Polygons are fan-triangulated; other data (normals, texture coordinates, colours) is skipped. The
// arrays are allocated by the parser; release them with od_Mesh_Free.
// OBJ: ASCII or UTF-8 text (a BOM is skipped) with LF, CRLF or CR line ends; a NUL byte (UTF-16, binary) is
// refused.
od_Status od_Mesh_ParseObj(const char* data, size_t size, od_Mesh* mesh);
// ascii, binary_little_endian and binary_big_endian PLY.
od_Status od_Mesh_ParsePly(const char* data, size_t size, od_Mesh* mesh);
void od_Mesh_Free(od_Mesh* mesh);

// Formats a mesh as OBJ text (17 significant digits) or binary little-endian PLY (float64 vertices, int32
// triangles). *data is allocated here; release it with od_Mesh_FreeData. Parsing and formatting poll the
// interrupt handler: on OD_ERROR_INTERRUPTED nothing is returned.
od_Status od_Mesh_FormatObj(int vertexCount, const double* vertices, int triangleCount, const int* triangles,
							char** data, size_t* size);
od_Status od_Mesh_FormatPly(int vertexCount, const double* vertices, int triangleCount, const int* triangles,
							char** data, size_t* size);
void od_Mesh_FreeData(char* data);

// ---------------------------------------------------------------------------------------------------------
// Goal frames from an animated mesh (goal_fit.c): per particle, the rigid motion that best carries its
// nearest rest vertices onto their animated positions; the input of od_Sim_SetGoals.

#define OD_MAX_GOAL_NEIGHBORS 64

typedef struct od_GoalFit od_GoalFit;

typedef struct od_GoalFitDef
{
	int vertexCount;
	const double* vertices; // vertexCount*3 rest positions, finite (copied)
	int neighbors;          // vertices per particle (16), at most OD_MAX_GOAL_NEIGHBORS
} od_GoalFitDef;

od_GoalFitDef od_DefaultGoalFitDef(void);
od_Status od_GoalFit_Create(const od_Graph* graph, const od_GoalFitDef* def, od_GoalFit** fit);
void od_GoalFit_Destroy(od_GoalFit* fit);
int od_GoalFit_GetVertexCount(const od_GoalFit* fit);
int od_GoalFit_GetNeighborCount(const od_GoalFit* fit); // k actually used (at most the vertex count)
// particleCount*k: each particle's vertices and their weights (summing to 1).
const int* od_GoalFit_GetIndices(const od_GoalFit* fit);
const double* od_GoalFit_GetWeights(const od_GoalFit* fit);
// animated: vertexCount*3 (the deformed rest vertices, same order); positions n*3, rotations n*9 written.
// OD_ERROR_ARGUMENT when a vertex used is not finite or a frame overflows (coordinates near 1e308); the
// outputs are then not frames.
od_Status od_GoalFit_Compute(const od_GoalFit* fit, const double* animated, double* positions, double* rotations);
// od_GoalFit_Compute of float32 vertices each moved by shift (3, float64): vertex + shift in float64, or the vertex
// alone where shift is zero (numpy's float64 copy of the vertices, then each column plus the shift where any is
// nonzero: the same bits). Blender's object-space positions placed by an unturned object's translation.
od_Status od_GoalFit_ComputeShifted(const od_GoalFit* fit, const float* animated, const double shift[3],
									double* positions, double* rotations);
// A frame's goal frames from Blender's input in one call: every vertex checked finite first (OD_ERROR_ARGUMENT naming
// the first that is not), then, unless the input is the one last fitted (*kept: vertexCount*3 float32 and the shift
// of the last fit, equal value for value, -0.0 to 0.0; *fitted = false, nothing written), od_GoalFit_ComputeShifted
// into positions and rotations, and the input and shift copied into kept (*fitted = true). On an error nothing is
// written and kept stays the last fit's.
typedef struct od_KeptInput
{
	float* vertices; // vertexCount*3
	double* shift;   // 3
	bool valid;      // false: no fit kept yet
} od_KeptInput;
od_Status od_GoalFit_Follow(const od_GoalFit* fit, const float* animated, const double shift[3], od_KeptInput* kept,
							bool* fitted, double* positions, double* rotations);

#ifdef __cplusplus
}
#endif
