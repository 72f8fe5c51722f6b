// Shared pieces of the opdeform._core binding (limited API 3.11): the object layouts, buffer helpers and
// status-to-exception mapping, so that each part of the module (graph and simulation, skinning, MPM) can
// live in its own file and stay thin.
#pragma once

#ifndef Py_LIMITED_API
#define Py_LIMITED_API 0x030B0000
#endif
#define PY_SSIZE_T_CLEAN
#include <Python.h>

#include "opdeform/opdeform.h"

typedef struct
{
	PyTypeObject* graphType;
	PyTypeObject* simType;
	PyObject* solverError; // opdeform._core.SolverError (RuntimeError)
} ModuleState;

typedef struct
{
	PyObject_HEAD od_Graph* graph;
} GraphObject;

typedef struct
{
	PyObject_HEAD od_Sim* sim;
	PyObject* graph; // keeps the od_Graph alive
	int busy;        // set while the GIL is released inside a call on this object
} SimObject;

// The od_Graph of a Graph object, or NULL with TypeError set.
const od_Graph* Binding_Graph(PyObject* module, PyObject* obj);
// obj as a Simulation, or NULL with TypeError set.
SimObject* Binding_Sim(PyObject* module, PyObject* obj);
// RuntimeError when the simulation is inside a GIL-free call on another thread.
int SimEnter(SimObject* self);

// Maps a core status to an exception carrying od_GetErrorMessage(); always returns NULL.
// ARGUMENT, SINGULAR -> ValueError; NOT_FOUND -> IndexError; MEMORY -> MemoryError; BUSY -> RuntimeError;
// anything else -> opdeform._core.SolverError.
PyObject* RaiseStatus(PyObject* module, od_Status status);

// A C-contiguous buffer of exactly `count` items of format fmt ('d' float64, 'i' int32, 'f' float32);
// ValueError naming `name` otherwise. Release with PyBuffer_Release / ReleaseArray.
int GetArray(PyObject* obj, const char* name, char fmt, Py_ssize_t count, int writable, Py_buffer* view);
// Same, but None is allowed (view->obj stays NULL).
int GetOptionalArray(PyObject* obj, const char* name, char fmt, Py_ssize_t count, Py_buffer* view);
void ReleaseArray(Py_buffer* view);
// Copies count items into a writable buffer.
int CopyOut(PyObject* out, const char* name, const void* data, Py_ssize_t count, char fmt);
// How many items of `itemsize` bytes a buffer holds, or -1 with ValueError.
Py_ssize_t ItemCount(PyObject* obj, const char* name, Py_ssize_t itemsize);

// Adds opdeform._core.Skin, graph_from_mesh, parse_mesh and format_mesh (mesh_binding.c).
int Binding_AddMesh(PyObject* module);

// Adds opdeform._core.MpmWorld (mpm_binding.c).
int Binding_AddMpm(PyObject* module);

// Adds opdeform._core.ShapeMatching (shape_matching_binding.c).
int Binding_AddShapeMatching(PyObject* module);
