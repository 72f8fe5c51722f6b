// The 8-particle chain of the state-loading fuzz targets (fuzz_sim_state, fuzz_contact_state, fuzz_goal_fit):
// particles 0.2 m apart along x, radii 0.1, edges between neighbours; tests/fuzz/make_state_corpus.py saves
// their seeds from the same chain. Made once; simulations borrow it.
#pragma once

#include "fuzz_input.h"

#include "opdeform/graph.h"

#define CHAIN_N 8

static const od_Graph* chain(void)
{
	static od_Graph* g = NULL;
	if (g)
	{
		return g;
	}
	double centers[CHAIN_N * 3] = { 0 }, radii[CHAIN_N * 3];
	int edges[(CHAIN_N - 1) * 2];
	for (int i = 0; i < CHAIN_N; ++i)
	{
		centers[3 * i] = 0.2 * i;
		radii[3 * i] = radii[3 * i + 1] = radii[3 * i + 2] = 0.1;
	}
	for (int e = 0; e < CHAIN_N - 1; ++e)
	{
		edges[2 * e] = e;
		edges[2 * e + 1] = e + 1;
	}
	od_GraphDef gd = od_DefaultGraphDef();
	gd.particleCount = CHAIN_N;
	gd.centers = centers;
	gd.radii = radii;
	gd.edgeCount = CHAIN_N - 1;
	gd.edges = edges;
	CHECK(od_Graph_Create(&gd, &g) == OD_OK);
	return g;
}
