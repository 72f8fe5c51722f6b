// opdeform._core: the thin CPython binding of the C core; this file only sets the module up.
//
// Built against the limited API 3.11 (one abi3 binary for every CPython >= 3.11, Blender's included).
// Arrays cross through the buffer protocol only (no numpy C API): callers hand in C-contiguous float64
// or int32 buffers of the right size, and getters fill caller-provided writable buffers. The Python layer
// (opdeform/*.py) converts arguments; the per-type files check sizes, map status codes to exceptions and
// release the GIL around the heavy calls. This is the one file that knows every type: the exec slot creates
// them from their specs into module state (the one place that holds them) and adds them to the module.
#include "goal_fit_binding.h"
#include "graph_binding.h"
#include "mesh_binding.h"
#include "mpm_binding.h"
#include "sim_binding.h"
#ifdef OD_BASELINES
#include "shape_matching_binding.h"
#endif

#include <string.h>

static PyObject* Module_allocation_count(PyObject* module, PyObject* unused)
{
	(void)module;
	(void)unused;
	return PyLong_FromLongLong(od_GetAllocationCount());
}

static PyMethodDef Module_methods[] = {
	{ "allocation_count", Module_allocation_count, METH_NOARGS, "allocations made by the C core so far" },
	{ NULL, NULL, 0, NULL },
};

// Creates the type of spec into *slot and adds it to the module under the last part of its name.
static int Module_AddType(PyObject* module, PyType_Spec* spec, PyTypeObject** slot)
{
	*slot = (PyTypeObject*)PyType_FromModuleAndSpec(module, spec, NULL);
	return *slot ? PyModule_AddObjectRef(module, strrchr(spec->name, '.') + 1, (PyObject*)*slot) : -1;
}

static int Module_exec(PyObject* module)
{
	ModuleState* st = Binding_State(module);
	st->solverError = PyErr_NewExceptionWithDoc("opdeform._core.SolverError",
												"A step or a static solve gave a non-finite result; the previous "
												"state is kept.",
												PyExc_RuntimeError, NULL);
	if (!st->solverError || PyModule_AddObjectRef(module, "SolverError", st->solverError) < 0 ||
		Module_AddType(module, &Graph_Spec, &st->graphType) < 0 ||
		Module_AddType(module, &Sim_Spec, &st->simType) < 0 ||
		Module_AddType(module, &Group_Spec, &st->groupType) < 0 || Module_AddType(module, &Skin_Spec, &st->skinType) < 0 ||
		Module_AddType(module, &GoalFit_Spec, &st->goalFitType) < 0 ||
		Module_AddType(module, &Mpm_Spec, &st->mpmType) < 0 || PyModule_AddFunctions(module, Mesh_Functions) < 0 ||
		Mesh_AddConstants(module) < 0)
	{
		return -1;
	}
#ifdef OD_BASELINES
	if (Module_AddType(module, &ShapeMatching_Spec, &st->smType) < 0)
	{
		return -1;
	}
#endif
	return PyModule_AddStringConstant(module, "__version__", OD_VERSION);
}

static int Module_traverse(PyObject* module, visitproc visit, void* arg)
{
	ModuleState* st = Binding_State(module);
	Py_VISIT(st->graphType);
	Py_VISIT(st->simType);
	Py_VISIT(st->groupType);
	Py_VISIT(st->skinType);
	Py_VISIT(st->goalFitType);
	Py_VISIT(st->mpmType);
	Py_VISIT(st->smType);
	Py_VISIT(st->solverError);
	return 0;
}

static int Module_clear(PyObject* module)
{
	ModuleState* st = Binding_State(module);
	Py_CLEAR(st->graphType);
	Py_CLEAR(st->simType);
	Py_CLEAR(st->groupType);
	Py_CLEAR(st->skinType);
	Py_CLEAR(st->goalFitType);
	Py_CLEAR(st->mpmType);
	Py_CLEAR(st->smType);
	Py_CLEAR(st->solverError);
	return 0;
}

static void Module_free(void* module)
{
	Module_clear((PyObject*)module);
}

static PyModuleDef_Slot Module_slots[] = {
	{ Py_mod_exec, Module_exec },
	{ 0, NULL },
};

static struct PyModuleDef Module_def = {
	PyModuleDef_HEAD_INIT,
	.m_name = "_core",
	.m_doc = "opdeform C core binding (limited API).",
	.m_size = sizeof(ModuleState),
	.m_methods = Module_methods,
	.m_slots = Module_slots,
	.m_traverse = Module_traverse,
	.m_clear = Module_clear,
	.m_free = Module_free,
};

PyMODINIT_FUNC PyInit__core(void)
{
	return PyModuleDef_Init(&Module_def);
}
