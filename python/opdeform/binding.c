// The shared part of the opdeform._core binding: module state access, the busy guard, status-to-exception
// mapping and buffer helpers (see binding.h). It calls into no per-type file.
#include "binding.h"

#include <string.h>

ModuleState* Binding_State(PyObject* module)
{
	return (ModuleState*)PyModule_GetState(module);
}

PyObject* Binding_Module(PyObject* obj)
{
	return PyType_GetModule(Py_TYPE(obj));
}

// ---------------------------------------------------------------------------------------------------------
// Busy guard

int Binding_Enter(PyObject* obj)
{
	if (!((GuardedObject*)obj)->busy)
	{
		return 0;
	}
	PyObject* name = PyType_GetName(Py_TYPE(obj));
	if (name)
	{
		PyErr_Format(PyExc_RuntimeError, "%U is busy: a call on another thread is running", name);
		Py_DECREF(name);
	}
	return -1;
}

// The core's interrupt handler while a call runs without the GIL (polled at most every 50 ms, base.h): takes
// the GIL back for PyErr_CheckSignals, which runs Python's signal handlers (Ctrl-C raises KeyboardInterrupt
// there) on the main thread; the exception stays set for Binding_Done. The object stays busy meanwhile.
static int Binding_SignalRaised(void* unused)
{
	(void)unused;
	PyGILState_STATE gil = PyGILState_Ensure();
	int raised = PyErr_CheckSignals() < 0;
	PyGILState_Release(gil);
	return raised;
}

PyThreadState* Binding_Release(void)
{
	od_SetInterruptHandler(Binding_SignalRaised, NULL);
	return PyEval_SaveThread();
}

void Binding_Reacquire(PyThreadState* ts)
{
	PyEval_RestoreThread(ts);
	od_SetInterruptHandler(NULL, NULL);
}

PyThreadState* Binding_Begin(PyObject* obj)
{
	((GuardedObject*)obj)->busy = 1;
	return Binding_Release();
}

void Binding_End(PyObject* obj, PyThreadState* ts)
{
	Binding_Reacquire(ts);
	((GuardedObject*)obj)->busy = 0;
}

// ---------------------------------------------------------------------------------------------------------
// Statuses

PyObject* RaiseStatus(PyObject* module, od_Status status)
{
	if (status == OD_ERROR_INTERRUPTED && PyErr_Occurred())
	{
		return NULL; // what the signal handler raised (KeyboardInterrupt for Ctrl-C)
	}
	PyObject* type;
	switch (status)
	{
		case OD_ERROR_ARGUMENT:
		case OD_ERROR_SINGULAR:
			type = PyExc_ValueError;
			break;
		case OD_ERROR_NOT_FOUND:
			type = PyExc_IndexError;
			break;
		case OD_ERROR_MEMORY:
			type = PyExc_MemoryError;
			break;
		case OD_ERROR_BUSY:
			type = PyExc_RuntimeError;
			break;
		case OD_ERROR_INTERRUPTED:
			type = PyExc_KeyboardInterrupt;
			break;
		default:
			type = Binding_State(module)->solverError;
			break;
	}
	PyErr_SetString(type, od_GetErrorMessage());
	return NULL;
}

PyObject* Binding_Done(PyObject* obj, od_Status status)
{
	if (status != OD_OK)
	{
		return RaiseStatus(Binding_Module(obj), status);
	}
	Py_RETURN_NONE;
}

PyObject* Binding_Id(PyObject* obj, od_Status status, int id)
{
	return status == OD_OK ? PyLong_FromLong(id) : RaiseStatus(Binding_Module(obj), status);
}

void Binding_Free(PyObject* obj)
{
	PyTypeObject* type = Py_TYPE(obj);
	freefunc tp_free = (freefunc)PyType_GetSlot(type, Py_tp_free);
	tp_free(obj);
	Py_DECREF(type);
}

// ---------------------------------------------------------------------------------------------------------
// Buffers

static const char* FormatName(char fmt)
{
	return fmt == 'd' ? "float64" : fmt == 'f' ? "float32" : "int32";
}

// The buffer's format letter is the one wanted; for int32 also 'l' where a C long is 32 bits (Windows: numpy's
// int32 arrays say 'l' there).
static int SameFormat(char want, char got)
{
	return got == want || (want == 'i' && got == 'l' && sizeof(long) == 4);
}

int GetArray(PyObject* obj, const char* name, char fmt, Py_ssize_t count, int writable, Py_buffer* view)
{
	memset(view, 0, sizeof *view);
	int flags = PyBUF_C_CONTIGUOUS | PyBUF_FORMAT | (writable ? PyBUF_WRITABLE : 0);
	if (PyObject_GetBuffer(obj, view, flags) < 0)
	{
		PyErr_Clear();
		PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous %s buffer", name, FormatName(fmt));
		return -1;
	}
	const char* f = view->format ? view->format : "B";
	if (*f == '<' || *f == '=' || *f == '@')
	{
		++f;
	}
	Py_ssize_t itemsize = fmt == 'd' ? 8 : 4; // 'i' int32, 'f' float32
	if (!SameFormat(fmt, f[0]) || f[1] != '\0' || view->itemsize != itemsize || view->len != count * itemsize)
	{
		PyErr_Format(PyExc_ValueError, "%s must hold %zd %s values (got %zd bytes of format '%s')", name, count,
					 FormatName(fmt), view->len, view->format ? view->format : "B");
		PyBuffer_Release(view);
		return -1;
	}
	return 0;
}

Py_ssize_t ItemCount(PyObject* obj, const char* name, Py_ssize_t itemsize)
{
	Py_buffer view;
	if (PyObject_GetBuffer(obj, &view, PyBUF_C_CONTIGUOUS) < 0)
	{
		PyErr_Clear();
		PyErr_Format(PyExc_ValueError, "%s must be a C-contiguous buffer", name);
		return -1;
	}
	Py_ssize_t count = view.len / itemsize;
	PyBuffer_Release(&view);
	return count;
}

int GetOptionalArray(PyObject* obj, const char* name, char fmt, Py_ssize_t count, Py_buffer* view)
{
	memset(view, 0, sizeof *view);
	return obj == Py_None ? 0 : GetArray(obj, name, fmt, count, 0, view);
}

void ReleaseArray(Py_buffer* view)
{
	if (view->obj)
	{
		PyBuffer_Release(view);
	}
}

void ReleaseArrays(Py_buffer* views, int count)
{
	for (int k = 0; k < count; ++k)
	{
		ReleaseArray(&views[k]);
	}
}

static int GetSpecArrays(PyObject* const* objs, const ArraySpec* specs, int count, int writable, Py_buffer* views)
{
	memset(views, 0, (size_t)count * sizeof *views);
	for (int k = 0; k < count; ++k)
	{
		const ArraySpec* s = &specs[k];
		int rc = s->optional ? GetOptionalArray(objs[k], s->name, s->fmt, s->count, &views[k])
							 : GetArray(objs[k], s->name, s->fmt, s->count, writable, &views[k]);
		if (rc < 0)
		{
			ReleaseArrays(views, count);
			return -1;
		}
	}
	return 0;
}

int GetArrays(PyObject* const* objs, const ArraySpec* specs, int count, Py_buffer* views)
{
	return GetSpecArrays(objs, specs, count, 0, views);
}

int GetOutArrays(PyObject* const* objs, const ArraySpec* specs, int count, Py_buffer* views)
{
	return GetSpecArrays(objs, specs, count, 1, views);
}

int GetInOutArrays(PyObject* const* objs, const ArraySpec* inSpecs, int inCount, Py_buffer* views,
				   const ArraySpec* outSpecs, int outCount, Py_buffer* outViews)
{
	if (GetArrays(objs, inSpecs, inCount, views) < 0)
	{
		return -1;
	}
	if (GetOutArrays(objs + inCount, outSpecs, outCount, outViews) < 0)
	{
		ReleaseArrays(views, inCount);
		return -1;
	}
	return 0;
}

void* ArrayData(const Py_buffer* view)
{
	return view->obj ? view->buf : NULL;
}

int CopyOut(PyObject* out, const char* name, const void* data, Py_ssize_t count, char fmt)
{
	Py_buffer view;
	if (GetArray(out, name, fmt, count, 1, &view) < 0)
	{
		return -1;
	}
	memcpy(view.buf, data, (size_t)view.len);
	PyBuffer_Release(&view);
	return 0;
}

int GetOptionalPoint(PyObject* obj, double t[3], int* given)
{
	*given = obj != Py_None;
	return *given && !PyArg_ParseTuple(obj, "ddd", &t[0], &t[1], &t[2]) ? -1 : 0;
}

// ---------------------------------------------------------------------------------------------------------
// State arrays

static const char* const StateNames[4] = { "positions", "rotations", "velocities", "angular_velocities" };

int StateArrayIndex(const char* name)
{
	for (int a = 0; a < 4; ++a)
	{
		if (strcmp(name, StateNames[a]) == 0)
		{
			return a;
		}
	}
	return -1;
}

Py_ssize_t StateArrayCount(int index, Py_ssize_t n)
{
	return (index == 1 ? 9 : 3) * n;
}

int GetStateArrays(PyObject* args, Py_ssize_t n, Py_buffer views[4])
{
	PyObject* arrays[4] = { NULL, NULL, Py_None, Py_None };
	memset(views, 0, 4 * sizeof *views);
	if (!PyArg_ParseTuple(args, "OO|OO", &arrays[0], &arrays[1], &arrays[2], &arrays[3]))
	{
		return -1;
	}
	ArraySpec specs[4];
	for (int a = 0; a < 4; ++a)
	{
		specs[a] = (ArraySpec){ StateNames[a], 'd', StateArrayCount(a, n), a >= 2 };
	}
	return GetArrays(arrays, specs, 4, views);
}

// ---------------------------------------------------------------------------------------------------------
// Force fields (opdeform/fields.h), the same calls on a Simulation's and an MpmWorld's set

// add(kind, strength, position, direction, turbulence, size, falloff, min_distance, max_distance, drag, seed)
static PyObject* AddField(PyObject* obj, od_FieldSet* set, PyObject* args)
{
	od_FieldDef d = od_DefaultFieldDef();
	int kind;
	double* p = d.position;
	double* a = d.direction;
	if (!PyArg_ParseTuple(args, "id(ddd)(ddd)ddddddI", &kind, &d.strength, &p[0], &p[1], &p[2], &a[0], &a[1], &a[2],
						  &d.turbulence, &d.size, &d.falloff, &d.minDistance, &d.maxDistance, &d.drag, &d.seed))
	{
		return NULL;
	}
	d.kind = (od_FieldKind)kind;
	int id = -1;
	od_Status status = od_FieldSet_Add(set, &d, &id);
	return Binding_Id(obj, status, id);
}

// move(id, position, direction or None)
static PyObject* MoveField(PyObject* obj, od_FieldSet* set, PyObject* args)
{
	int id, given;
	double p[3], a[3];
	PyObject* direction;
	if (!PyArg_ParseTuple(args, "i(ddd)O", &id, &p[0], &p[1], &p[2], &direction) ||
		GetOptionalPoint(direction, a, &given) < 0)
	{
		return NULL;
	}
	return Binding_Done(obj, od_FieldSet_Move(set, id, p, given ? a : NULL));
}

PyObject* Binding_Field(PyObject* obj, od_FieldSet* set, PyObject* args)
{
	Py_ssize_t count = PyTuple_Size(args);
	PyObject* rest = count >= 1 ? PyTuple_GetSlice(args, 1, count) : NULL;
	const char* op = count >= 1 ? PyUnicode_AsUTF8AndSize(PyTuple_GetItem(args, 0), NULL) : NULL;
	int id;
	PyObject* result = NULL;
	if (!rest || !op)
	{
		PyErr_Clear();
		PyErr_SetString(PyExc_TypeError, "force_field(op, ...): op is 'add', 'move', 'remove' or 'count'");
	}
	else if (strcmp(op, "add") == 0)
	{
		result = AddField(obj, set, rest);
	}
	else if (strcmp(op, "move") == 0)
	{
		result = MoveField(obj, set, rest);
	}
	else if (strcmp(op, "remove") == 0)
	{
		result = PyArg_ParseTuple(rest, "i", &id) ? Binding_Done(obj, od_FieldSet_Remove(set, id)) : NULL;
	}
	else if (strcmp(op, "count") == 0)
	{
		result = PyLong_FromLong(od_FieldSet_Count(set));
	}
	else
	{
		PyErr_Format(PyExc_ValueError, "force_field: unknown op '%s'", op);
	}
	Py_XDECREF(rest);
	return result;
}
