// opdeform._core.Graph (graph_binding.c): the spec, and what the other types need of a graph.
#pragma once

#include "binding.h"

extern PyType_Spec Graph_Spec;

// The od_Graph of a Graph object, or NULL with TypeError ("graph must be ...").
const od_Graph* Graph_FromObject(PyObject* module, PyObject* obj);
// A new Graph object owning graph; on failure graph is destroyed and NULL returned.
PyObject* Graph_Wrap(PyObject* module, od_Graph* graph);
