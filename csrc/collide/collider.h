// Signed-distance colliders shared by the subsystems that collide (collider.c): a shape in its own frame,
// and the frame moving from the start of a call to a target.
#pragma once

#include "math3.h"
#include "opdeform/base.h"

#include <stdbool.h>
#include <stddef.h>

typedef enum od_ShapeKind
{
	OD_SHAPE_PLANE = 0,  // the half space z < 0 of the collider's frame
	OD_SHAPE_BOX = 1,    // |x|, |y|, |z| <= halfExtents
	OD_SHAPE_SPHERE = 2, // radius halfExtents[0]
	OD_SHAPE_MESH = 3,   // a closed triangle mesh, sampled as distances (sign: parity of crossings)
	OD_SHAPE_CAPSULE = 4, // radius halfExtents[0] about the segment |z| <= halfExtents[2] of the z axis
	OD_SHAPE_OPEN_MESH = 5 // an open triangle mesh, sampled (sign: the side of the nearest triangle)
} od_ShapeKind;

typedef struct od_ShapeDef
{
	od_ShapeKind kind;
	double halfExtents[3];
	int vertexCount;
	const double* vertices; // vertexCount*3 (mesh; not kept)
	int triangleCount;
	const int* triangles;   // triangleCount*3 (mesh; not kept)
	double spacing;         // the finest distance sample spacing a mesh needs
	int resolution;         // mesh: at most this many samples along its longest side (0: as many as allowed)
	bool detectOpen;        // OD_SHAPE_MESH: becomes OD_SHAPE_OPEN_MESH when an edge lacks its second triangle
} od_ShapeDef;

typedef struct od_Collider
{
	od_ShapeKind kind;
	double halfExtents[3];
	// mesh: signed distance samples on a local grid
	double* sdf;
	double* side;    // open mesh: per sample, the cosine to its nearest triangle's normal (while sampling)
	size_t capacity; // samples allocated
	int dims[3];
	double origin[3], spacing, minSpacing;
	int resolution;
	double radius; // bounding radius about the frame origin (for speed bounds)
	// frames: at the start of the current call, its target, and the velocity over the call
	od_Mat3 R0, R1;
	od_Vec3 t0, t1;
	od_Vec3 omega, velocity;
	// the frame placed last (od_Collider_Place)
	od_Mat3 R;
	od_Vec3 t;
} od_Collider;

od_Status od_Collider_Init(od_Collider* c, const od_ShapeDef* def, const double rotation[9], const double translation[3]);
void od_Collider_Destroy(od_Collider* c);
// The frame at the end of the next call; rotation must be proper.
od_Status od_Collider_SetTarget(od_Collider* c, const double rotation[9], const double translation[3]);
// Starts a call of length `duration`: velocities from the current frame to the target.
void od_Collider_BeginCall(od_Collider* c, double duration);
// Sets the frame at fraction s in [0, 1] of the current call.
void od_Collider_Place(od_Collider* c, double s);
// The frame at fraction s of the current call, without placing it.
void od_Collider_FrameAt(const od_Collider* c, double s, od_Mat3* R, od_Vec3* t);
// New vertices of a mesh collider (same triangles, in its frame): re-sampled; on failure (out of memory and
// OD_ERROR_INTERRUPTED included: polled with od_CheckInterrupt) nothing changed.
od_Status od_Collider_SetVertices(od_Collider* c, const double* vertices, int vertexCount, const int* triangles,
								  int triangleCount);
// Whether every edge of the triangles is shared by exactly two (closed), and a triangle wound against a
// neighbour (-1 when none). Indices must be in range. The edges are sorted with od_Sort (polls for interrupts:
// OD_ERROR_INTERRUPTED; stable, so ties keep their input order, as glibc's merging qsort did).
od_Status od_Collider_MeshTopology(const int* triangles, int triangleCount, bool* closed, int* flipped);
void od_Collider_EndCall(od_Collider* c);
double od_Collider_MaxSpeed(const od_Collider* c);
// Signed distance (negative inside) and world normal at world point x for the placed frame (a mesh skips
// the normal outside, where no caller needs it).
double od_Collider_Distance(const od_Collider* c, od_Vec3 x, od_Vec3* n);
// Signed distance and outward normal at point p of the collider's own frame (a mesh's normal outside too);
// n NULL: the distance alone (a sampled mesh's normal costs six more lookups of its grid).
double od_Collider_LocalDistance(const od_Collider* c, od_Vec3 p, od_Vec3* n);
// The collider's velocity at world point x over the current call.
od_Vec3 od_Collider_Velocity(const od_Collider* c, od_Vec3 x);
