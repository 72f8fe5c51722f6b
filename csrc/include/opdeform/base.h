// opdeform: status codes and error reporting shared by every part of the C core.
//
// Every fallible function returns an od_Status. On failure a message naming the argument and the
// problem is kept per thread and can be read with od_GetErrorMessage() until the next failure on the
// same thread. The core never aborts and never prints.
#pragma once

#ifdef __cplusplus
extern "C" {
#endif

#define OD_VERSION_MAJOR 0
#define OD_VERSION_MINOR 1
#define OD_VERSION_PATCH 0

typedef enum od_Status
{
	OD_OK = 0,
	OD_ERROR_ARGUMENT,     // an input is malformed: shape, range, NaN, improper frame...
	OD_ERROR_NOT_FOUND,    // an unknown constraint id
	OD_ERROR_MEMORY,       // an allocation failed
	OD_ERROR_SINGULAR,     // the global matrix is not positive definite (an unconstrained static pose)
	OD_ERROR_NOT_FINITE,   // a step produced NaN or infinity; the previous state was kept
	OD_ERROR_BUSY,         // the object is being used by another thread
	OD_ERROR_INTERNAL,     // a library call (CHOLMOD) failed unexpectedly
	OD_ERROR_INTERRUPTED,  // the interrupt handler asked a long call to stop (od_SetInterruptHandler)
} od_Status;

// The message of the last failure on the calling thread ("" when none).
const char* od_GetErrorMessage(void);

// A short constant name for a status ("OD_ERROR_ARGUMENT").
const char* od_StatusName(od_Status status);

// How many allocations the core has made so far (all threads): tests use it to check that a warmed-up
// step allocates nothing.
long long od_GetAllocationCount(void);

// Interrupting long calls (a host's Ctrl-C). The handler set on a thread is polled by the long calls that
// thread makes, at most every 50 ms of their work, between steps (od_Sim_Step), iterations (a static solve,
// shape matching), MPM substeps, a mesh collider's triangles, the voxels and sorts of a graph built from a
// mesh, the vertices a skin binds and the lines or items of a mesh file read or written;
// when it returns nonzero the call stops with OD_ERROR_INTERRUPTED: ARAP and shape-matching calls keep the
// state from before the call (as any failure), an MPM step keeps the state at the last whole substep. NULL
// removes it. The core's own worker threads never call it.
typedef int od_InterruptFn(void* context);
void od_SetInterruptHandler(od_InterruptFn* handler, void* context);

#ifdef __cplusplus
}
#endif
