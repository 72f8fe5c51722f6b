// The shared part of the opdeform._core binding (limited API 3.11), used by every per-type file:
// module state, the busy guard, status-to-exception mapping and the buffer helpers. It knows no type:
// _core.c creates the types from the specs the per-type files export and keeps them in module state.
//
// Files: _core.c (module set-up) -> graph_binding.c, sim_binding.c, mesh_binding.c, mpm_binding.c,
// shape_matching_binding.c (OD_BASELINES) -> binding.c. A per-type file may use a lower one's header
// (the Graph type check and wrapper in graph_binding.h), never the other way round.
#pragma once

#ifndef Py_LIMITED_API
#define Py_LIMITED_API 0x030B0000
#endif
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "opdeform/opdeform.h"

// The heap types and the exception, the one place that holds them.
typedef struct
{
	PyTypeObject* graphType;
	PyTypeObject* simType;
	PyTypeObject* groupType;
	PyTypeObject* skinType;
	PyTypeObject* goalFitType;
	PyTypeObject* mpmType;
	PyTypeObject* smType;    // NULL without OD_BASELINES
	PyObject* solverError;   // opdeform._core.SolverError (RuntimeError)
} ModuleState;

ModuleState* Binding_State(PyObject* module);
// The module of an object of one of the module's types.
PyObject* Binding_Module(PyObject* obj);

// ---------------------------------------------------------------------------------------------------------
// The busy guard. Every object whose calls release the GIL starts with this head; while such a call runs,
// every call on the object from another thread is refused with RuntimeError ("<Type> is busy: ...").
typedef struct
{
	PyObject_HEAD int busy;
} GuardedObject;

// 0 when obj may be used; -1 with RuntimeError while a GIL-free call on it runs. Call first in every method.
int Binding_Enter(PyObject* obj);
// Marks obj busy, sets the core's interrupt handler (signals are checked, with the GIL, at most every 50 ms
// of the call) and releases the GIL; Binding_End takes the GIL back and clears both.
PyThreadState* Binding_Begin(PyObject* obj);
void Binding_End(PyObject* obj, PyThreadState* ts);
// The same for a call that uses no object yet (building one: a graph from a mesh, a skin, a parsed file).
PyThreadState* Binding_Release(void);
void Binding_Reacquire(PyThreadState* ts);

// ---------------------------------------------------------------------------------------------------------
// Statuses

// Maps a core status to an exception carrying od_GetErrorMessage(); always returns NULL.
// ARGUMENT, SINGULAR -> ValueError; NOT_FOUND -> IndexError; MEMORY -> MemoryError; BUSY -> RuntimeError;
// INTERRUPTED -> the exception a signal handler raised (KeyboardInterrupt); anything else ->
// opdeform._core.SolverError.
PyObject* RaiseStatus(PyObject* module, od_Status status);
// None for OD_OK, else RaiseStatus for the module of obj.
PyObject* Binding_Done(PyObject* obj, od_Status status);
// The id as an int for OD_OK, else RaiseStatus for the module of obj.
PyObject* Binding_Id(PyObject* obj, od_Status status, int id);

// Frees an object of a heap type (the tail of every tp_dealloc).
void Binding_Free(PyObject* obj);

// ---------------------------------------------------------------------------------------------------------
// Arguments and buffers

// A C-contiguous buffer of exactly `count` items of format fmt ('d' float64, 'i' int32, 'f' float32);
// ValueError naming `name` otherwise. Release with PyBuffer_Release / ReleaseArray.
int GetArray(PyObject* obj, const char* name, char fmt, Py_ssize_t count, int writable, Py_buffer* view);
// Same, but None is allowed (view->obj stays NULL).
int GetOptionalArray(PyObject* obj, const char* name, char fmt, Py_ssize_t count, Py_buffer* view);
void ReleaseArray(Py_buffer* view);
// ReleaseArray on each of count views (zeroed or held).
void ReleaseArrays(Py_buffer* views, int count);

// An array argument: its name, format, item count, and whether None is allowed.
typedef struct
{
	const char* name;
	char fmt;
	Py_ssize_t count;
	int optional;
} ArraySpec;

// GetArray / GetOptionalArray for each of count objects by its spec; on failure none is held.
int GetArrays(PyObject* const* objs, const ArraySpec* specs, int count, Py_buffer* views);
// The same for arrays written into (outputs; the specs not optional).
int GetOutArrays(PyObject* const* objs, const ArraySpec* specs, int count, Py_buffer* views);
// GetArrays for inCount inputs, then GetOutArrays for the outCount objects after them; on failure none is held.
int GetInOutArrays(PyObject* const* objs, const ArraySpec* inSpecs, int inCount, Py_buffer* views,
				   const ArraySpec* outSpecs, int outCount, Py_buffer* outViews);
// The buffer's data, or NULL for an optional array that was None.
void* ArrayData(const Py_buffer* view);
// Copies count items into a writable buffer.
int CopyOut(PyObject* out, const char* name, const void* data, Py_ssize_t count, char fmt);
// How many items of `itemsize` bytes a buffer holds, or -1 with ValueError.
Py_ssize_t ItemCount(PyObject* obj, const char* name, Py_ssize_t itemsize);
// A target (x, y, z) into t, or None (*given = 0); -1 with an exception otherwise.
int GetOptionalPoint(PyObject* obj, double t[3], int* given);

// The state of a particle system: positions (n*3), rotations (n*9), velocities and angular velocities
// (n*3 or None), as in set_state(positions, rotations, velocities=None, angular_velocities=None).
// Parses set_state's arguments for n particles into views[4] (release with ReleaseArrays); on failure
// nothing is held.
int GetStateArrays(PyObject* args, Py_ssize_t n, Py_buffer views[4]);
// The index of name among the state arrays' names, or -1 when it is none of them.
int StateArrayIndex(const char* name);
// How many values state array `index` holds for n particles.
Py_ssize_t StateArrayCount(int index, Py_ssize_t n);

// The parameters shared by od_SimDef and od_ShapeMatchingDef: positional (stiffness, density, dt, iterations,
// gravity, damping, skin_neighbors), and the dict that params() returns.
#define BINDING_DEF_FORMAT "dddi(ddd)di"
#define BINDING_DEF_ARGS(d)                                                                                        \
	&(d).stiffness, &(d).density, &(d).dt, &(d).iterations, &(d).gravity[0], &(d).gravity[1], &(d).gravity[2],    \
		&(d).damping, &(d).skinNeighbors
#define BINDING_DEF_DICT(d)                                                                                        \
	Py_BuildValue("{sdsdsdsis(ddd)sdsi}", "stiffness", (d).stiffness, "density", (d).density, "dt", (d).dt,        \
				  "iterations", (d).iterations, "gravity", (d).gravity[0], (d).gravity[1], (d).gravity[2],          \
				  "damping", (d).damping, "skin_neighbors", (d).skinNeighbors)

// ---------------------------------------------------------------------------------------------------------
// Force fields (opdeform/fields.h): the methods of every type that has a field set, after its busy guard.

// force_field(op, ...) of a type with a field set: ("add", kind, strength, position, direction, turbulence,
// size, falloff, min_distance, max_distance, drag, seed) -> id, ("move", id, position, direction or None),
// ("remove", id), ("count",) -> count.
PyObject* Binding_Field(PyObject* obj, od_FieldSet* set, PyObject* args);
