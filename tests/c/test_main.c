// Runs every C unit test; exits non-zero when one fails. Prints "N passed, N failed".
#include "test_macros.h"

int test_polar(void);
int test_svd4(void);
int test_graph(void);
int test_sim(void);
int test_group(void);
int test_interrupt(void);
int test_goal(void);
int test_auto(void);
int test_mpm(void);
int test_mesh_graph(void);
int test_loose_parts(void);
int test_skinning(void);
int test_goal_fit(void);
int test_mesh_io(void);
int test_cholesky(void);

int main(void)
{
	int failures = 0, total = 0;
	RUN_TEST(test_polar);
	RUN_TEST(test_svd4);
	RUN_TEST(test_graph);
	RUN_TEST(test_sim);
	RUN_TEST(test_group);
	RUN_TEST(test_interrupt);
	RUN_TEST(test_goal);
	RUN_TEST(test_auto);
	RUN_TEST(test_mpm);
	RUN_TEST(test_mesh_graph);
	RUN_TEST(test_loose_parts);
	RUN_TEST(test_skinning);
	RUN_TEST(test_goal_fit);
	RUN_TEST(test_mesh_io);
	RUN_TEST(test_cholesky);
	printf("%d passed, %d failed\n", total - failures, failures);
	return failures ? 1 : 0;
}
