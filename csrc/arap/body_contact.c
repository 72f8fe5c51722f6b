// Contact between particles (docs/contact.md): of the simulations of a group (contact_group.c) and of
// distant parts of one simulation (self-contact).
//
// Between the bodies of a group, contact acts inside the iterations of a step, as forces on the right side of
// every global solve (sim->contactForce, global_solve.c), and after them as a projection; so does self-contact,
// with forces of its own (below).
//
// Narrow phase: ellipsoid i reaches s_i = sqrt(nᵀ M_i n) along a unit n (M_i = E diag(a², b², c²) Eᵀ), so
// the half spaces n·(p - x_i) <= s_i and n·(p - x_j) >= -s_j hold the two ellipsoids: when n·(x_j - x_i) >=
// s_i + s_j they are apart (conservative: exact along the centre line, never misses an overlap). A pair
// closer than s_i + s_j + thickness is in contact. The direction: a pair apart at the step's start keeps the
// start's centre line, and is tested only when its relative path came within reach: a fast particle cannot
// pass through another, whatever its speed. A pair that began overlapping (placed so, or excluded before)
// uses the end's centre line (between members, its push direction, turned back towards the start's centre line while
// it began less than OD_OVERLAP_TURN thicknesses deep: od_OverlapNormal) and leaves at 1 m/s at most, as the
// colliders' (contact.c). Pairs push along
// the centre line turned towards the bodies' surface normals there (od_PushDirection), but for a pair apart at the
// start that is its members' only contact, at steps of 1/60 s or shorter, which pushes along the line it is measured
// on: pushed off it, its force did work (a Suzanne resting on another on one pair gained 509 J; od_PushAlong).
// Between two bodies either of which has a contact skin (Simulation.set_contact_skin), the shapes are its carried
// skin points and the pair is measured and pushed along a separating axis instead (od_SkinNormal, skin_pairs.c).
//
// Forces (od_IterateWithForces): each pair in contact carries a normal force f >= 0 and a friction force t,
// |t| <= μ f, on b (their negatives on a). After every global solve of the step (all members of the group at
// the same iteration) they are updated by dual ascent towards the pair's constraints: f grows by a rate
// times the depth beyond the allowed one and shrinks while the pair is apart; t grows against the pair's
// relative tangential displacement since the step's start, so friction is a constraint on the whole step,
// not re-applied per iteration, and against a share (OD_ANCHOR_PULL) of its slip before the step since it began to
// stick (its anchor, od_Slip; kept while t is inside its bound, taken anew where it reaches it: the pair slides), so
// what a step's truncated iterations leave does not add up to a creep (Müller et al. 2020 and IPC keep such an
// anchor while a contact sticks); both measured in the frame of the pair's first particle (od_Turning), so that
// members turning together read no slip. The next solve sees them (its matrix unchanged: the forces are on the right
// side only), and the local step then fits the rotations to positions that already hold the contact. The
// forces start each step where the last one left them (warm start: matched by particle pair), so a resting
// contact carries its weight from the first solve. Why (docs/contact.md, stacking): the projection after the
// iterations strained the bodies and the next solve gave the strain back as motion; a bar on a bar turned
// and rolled off at any friction, with the forces it rests. A force never vanishes at once between members that
// press each other (comparable or braced): a pair the broad phase no longer finds, or pushed beyond reach in the
// first solve, keeps it to fade by the rate times how far it is beyond reach (od_CarryForces, od_GatherNear).
//
// Each update first takes one Newton step of the members' rigid motions (od_Coarse): the contacts between
// two members form an interface whose mean gap, with the members as rigid bodies (mass M, h²/M per newton)
// and each contact's particles adding their own compliance (the inverse of their rows' diagonal in the
// global matrix), asks for a change of its total normal force; the interfaces' small dense system is solved
// and the change spread evenly over each interface's contacts, whose own updates then act on their gaps less
// the mean. A particle's own rate alone (its m/h²) moves a stiff body by the share of its particles that
// touch: two Rubber spheres stacked rolled off within 3 s (the lower one's pairs never caught up with the
// upper's lean); with the rigid step they rest 13 s. Friction takes the same step at steps longer than 1/60 s
// (od_CoarseFriction): a Stiff slab on one half as dense at 1/24 s, resting on 5 of its particles, crept off as
// their friction lagged their leaning normals. A member on its floor pushed down by its pairs gets the floor's
// reaction in the solves (od_FloorReaction) and is held vertically in the rigid step. Both only between members
// within OD_COMPARABLE of each other's mass (od_Comparable: beyond, drops gained energy).
// A member resting on much heavier ones takes its pairs' forces at its rigid rate shared over them instead
// (od_PerchedRates).
// Beyond it, a member supported from the floor up stands immovable and still to a heavier one resting on it
// (shock propagation, od_Braced, od_Brace): its pairs' forces and pushes stop the heavy one alone, so it is
// never pushed through the floor and passed through (slabs 100 to 1e6 times as dense as the one below rest on
// top).
// A member that meets its floor with its skin and the other members with its ellipsoids (od_FloorSkinOnly: the
// add-on's default) takes neither the reaction nor the vertical hold, nor od_Held's push (s->held): its floor acts
// after the iterations alone, as a scene collider does. The reaction is spread by how its ellipsoids bear and given
// whole whatever the member does in the solves: a subdivided Suzanne at the add-on's defaults (Rubber, 240 steps a
// second) landed on at 4.4 m/s by another had its bottom lifted off the floor by it (its lowest particle 1 cm in 3
// steps, the floor lifting nothing), where on a Collision plane the same bottom was pressed in and lifted back
// after the iterations; it rocked back to 45° and threw the upper one up and off (2.28 m aside at 3 s). Without
// them the floor steps as a plane collider of no thickness (the same positions within 1e-5 m over the first second,
// the landing in it), and the upper one rests on top (0.26-0.29 m aside, 2.02 before; docs/contact.md, "Stacks",
// twelfth round: a marginal stack, off from 1.02 m on either). With its skin between the members too they stay:
// without them the blobs of tests/test_skin_pairs.py dropped on each other went 6.1 % of their size into each other
// (2 % the bound). Such a member still braces (above). Its floor so resisted no lean: two of the add-on's Jelly
// spheres stacked tipped over as one and rolled off (1.45 m aside at 3 s). So, at steps of OD_MEMBER_ROLL_STEP or
// shorter and outside impacts (od_Landing), one that comparable members press onto its floor rolls back on its
// floor's patch after the projections, as a lone body does (surface_contact.c, od_SurfaceContact_GroupRoll: the
// patch from the floor's lifts), and one of the same kind resting on it on its pairs' patch there
// (od_PatchRolls): Jelly 0.077 m aside at 3 s, Flesh 0.044 (0.87 m before; docs/contact.md, "Stacks", stop 37).
// At steps longer than OD_MEMBER_ROLL_STEP a member meeting everything with its ellipsoids (the stacking bench's)
// rolls back the same way (od_PatchRolling): there the floor's couple in the solves (od_Rolls) hardly turns it. Two
// Rubber spheres stacked at 1/24 s: over a step's three updates the lower's couple tripled (10 to 30 N m, its bound
// 70) and its turn in the step changed by under 1 %; updated at every solve the couples reached their bounds and the
// turn fell 20 % in 49 updates. They tipped over as one and rolled off (Jelly 0.80, Rubber 0.68 m aside); with the
// patch's roll they rest on top (0.088 and 0.027 m; docs/contact.md, "Stacks", stop 38).
// Each member turns about its own patch there, outside the iterations' friction: rolled back, a lower one slid its
// top from under the one resting on it (0.5 mm a step), which crept off. So after the members' finish a member
// resting on others is carried, rigidly and level, by what the finish slid them under it (od_BodyContact_Carry;
// docs/contact.md, "Stacks", stop 41).
//
// Rolling resistance on the floor (od_Rolls, od_ApplyRolls): a group's floor acts after the iterations, on the
// particles' centres, and its friction pins the centres of the particles that bear: a round member rolls over them
// as over bumps. Two Jelly spheres stacked tipped over as one, the lower rolling on its floor (both turning the same
// way, 0.005 rad a step at 60 Hz; held from turning relative to each other by a couple between them they fell as
// before). What holds a real one is its contact patch, the pressure moving towards the patch's front edge. So a
// member on its floor that its comparable pairs push down takes a couple about horizontal axes in the solves
// against its rotation since the step's start, at most OD_ROLL_REACH times that push times its bearing particles'
// mean largest radius (the patch each stands for), as a rigid rotation's forces (no net force, no strain); it
// starts at none each step (so it is no part of the group's state), is held after OD_ROLL_UPDATES updates and
// is left out at an impact (OD_ROLL_LANDING). A member that meets its floor with its skin and the others with its
// ellipsoids (od_FloorSkinOnly: the add-on's default) takes none: the bound is its ellipsoids' patch, and the
// add-on's firm blobs (k = 1e7, 24 fps) crept 0.097 m apart in 4 s with it, 0.036 without
// (test_two_firm_blobs_dropped_one_on_the_other_come_to_rest_stacked). One that meets the others with its skin too
// takes it, as it takes the floor's reaction: without it two Rubber spheres stacked on their skins tipped over as
// one, the lower rolling on its floor (docs/contact.md, "Stacks", stop 37, skinstack).
// Between two comparable members in contact (od_MemberRolls) a couple of the same kind and bound acts against their
// relative turn, on the upper one and its negative on the lower (no net force or torque), the interface's normal
// force as the push: a subdivided Suzanne dropped on another at the add-on's defaults (240 steps a second, the
// ellipsoids between them) slid 0.58-0.74 m aside over the lower's head in bpy 5.2, at 0.18 m/s at 3 s; with it
// it rests at 0.26-0.29 m (docs/contact.md, "Stacks", tenth round). Not at steps longer than OD_MEMBER_ROLL_STEP.
//
// Inelastic impacts (od_BodyContact_Impacts, after each group step): a member that meets its floor and colliders with
// its skin and the others with its ellipsoids (od_FloorSkinOnly) lands on its floor as on a projection, which stops
// what it lifts, and on another member on the pairs' forces inside the solves, which gave back what a soft member's
// squash stores: a Jelly Suzanne dropped 1 m onto another at the add-on's defaults left it at 3.7 m/s up (a lone
// one landing on the floor at 4.7 m/s rises 0.03 m), the lower bouncing off its floor at 1.5 m/s under it, and lay
// 2.7 m aside at 3 s. So, as a rigid body step takes a contact's restitution (Guendelman, Bridson and Fedkiw 2003:
// contact at zero restitution), two such comparable members whose pairs carry a force and part along their mean
// normal faster than gravity gives in a step or OD_CLIMB_TIME, the longer, are slowed to that speed, the change
// split by mass (momentum kept), and one of them pressed onto its floor and rising off it or a collider faster than
// that is slowed the same way, in OD_IMPACT_PASSES Gauss-Seidel passes; members that goals or pins hold take
// neither (od_Driven); a whole member's velocity is shifted, nothing turns or strains,
// positions are left as the step put them; without gravity nothing is taken. The Suzanne rests on the lower's
// head, 0.75 m aside (docs/contact.md, "Stacks", stop 38, jellysuz). The members' part acts on every comparable
// pair of members that meet each other with their ellipsoids (od_MembersOnEllipsoids): kept to those that meet
// their floor with their skins, two Rubber creatures of the engine dropped 0.1 m one on the other at 240 steps a
// second (their floor inside the iterations) bounced apart at the landing and the upper slid off (1.10 m aside at 9
// s); with it, 0.10 m at 13 s (docs/contact.md, "Stacks", stop 44). Between members on their skins
// (set_contact_skin with bodies) it tipped two Rubber spheres stacked on their skins off (0.32 m aside, 0.73 m/s at
// 3 s). The ground's part only for those that meet their floor with their skins (od_FloorSkinOnly): where the floor
// holds a member inside the iterations (od_FloorReaction), it gives back what that takes, and the same creatures
// gained 5.2 kJ over their 4.5 kJ start (stop 38: 5.1 kJ, with two Rubber spheres on their skins, held together,
// bouncing on their floor as one at 1.1-1.4 m/s).
//
// Projection (od_ProjectPairs): after the iterations, the pairs in contact are pushed apart by the remaining
// depth, split by mass (the lighter moves more), in four Gauss-Seidel passes, then their relative tangential
// displacement is cut by at most μ times the push (Coulomb, position based, as the floor). A stack of two
// bodies settles in four passes (one pass left the upper blob sinking 3 mm a step). At rest the forces hold
// the pairs and it pushes nothing; it keeps fast pairs from passing through each other. A small push that
// presses a member down onto the floor holding it moves the upper end alone (od_Held).
//
// A group with inIterations = 0 has no forces: the projection alone, as before them, its step a function of
// its members' states. With forces, the group's pairs and forces are its state (od_ContactGroup_GetPairs /
// SetPairs, contact_group.c): the Blender add-on caches them with each frame.
//
// Self-contact's forces (od_IterateSelf): a pin or a goal pulls a tail through its own body with a force that
// re-enters every solve, which the projection after the iterations alone did not stop (a tail pulled past its
// root went 21.5 mm into it, 54-73 mm under goals of strength 0.9-1.0). After a step's first solve, the pairs
// near then each become a half-space along their centre line at the step's start, and their normal forces are
// those that hold all of them at the centres of the next solve, computed exactly from the solve's response
// between their particles (A⁻¹, od_SelfResponse: the matrix, pins and goals included, is fixed during a step)
// by projected Gauss-Seidel: so a pull of any strength is met by the force that stops it, split between the
// two sides as the solve's own stiffnesses split it. Friction is solved with them (od_SolveForces): with the
// normal held by forces the projection pushes almost nothing, so its friction, bounded by its push, held nothing
// (a hook's tail slid off its own body, tests/blender/suite_colliders.py); each pair's own Newton step, not
// coupled, never let the rod's ends held pressed settle (fastest particle 0.47 m/s after 10 s, measured with
// two details since dropped). Nothing is
// carried from step to step (no warm start): a step stays a function of the state, which is what the add-on
// caches. Measured (docs/contact.md): the tails' deepest overlap 2.1 / 0.9 / 0.6 mm (a pin, goals of strength
// 0.9, 1.0; 21.5 / 73 / 54 mm with the projection alone), the rod's ends held pressed 4.5 mm apart.
//
// Exclusion (self-contact): pairs joined by at most `exclusionRing` edges, or closer at rest than
// `exclusionScale` times the sum of their largest radii, never collide: the overlaps a body has at rest are
// not contact, so a body at rest stays at rest to the bit (tests/test_body_contact.py).
// Between two members whose goals carry the rest, pairs whose goal centres are closer than `exclusionScale` times the
// sum of their largest reaches never collide (od_TogetherAtGoals): what the animation puts together is not contact.
// A jacket 5 % larger than its body on one armature, both jiggling, started interpenetrating and blew up (stretch 7x).
//
// Broad phase, once a step at its end: a uniform grid over the spheres that bound each particle's path over
// the step (the midpoint of its start and end, radius its largest radius plus half its motion and half the
// thickness), cells of the largest diameter, hashed into a table of 2n rounded to a power of two and sorted
// by counting; each particle meets those of the 27 cells about it with a larger index. Linear in n for
// particles of similar size; measured on a 10,000-particle beam: docs/contact.md. The next step's forces use
// these pairs (those near after its first solve, od_GatherNear); a pair that meets only later in the step is
// the projection's, with the pairs of that step's end.
#include "body_contact.h"
#include "tolerance.h"

#include "contact.h"
#include "core.h"
#include "energy.h"
#include "floor.h"
#include "global_solve.h"
#include "goal.h"
#include "math3.h"
#include "skin_pairs.h"
#include "skin_shape.h"
#include "step.h"

#include <math.h>
#include <stdint.h>
#include <string.h>

#define OD_FAR_CELL 4503599627370496.0 // 2^52: od_Cell's bound
#define OD_PAIR_PASSES 4
// The forces' rate over that of two free particles (od_UpdatePair). Measured on the stack of two bars
// (docs/contact.md): 0.3, 1, 2 and 3 all kept it; the upper bar's fastest particle at 6 s was 0.062, 0.018,
// 0.0027 and 0.0025 m/s, and 2 was chosen, while the first solve saw a part of the warm start only
// (od_NewPairs). With all of it (docs/contact.md, fourth round): 1 keeps the bars (0.013 m/s) and the
// add-on's blob dropped on a blob at 1/24 s (skinned overlap -0.018 m, with the normal re-aimed every
// update); 2 overshot there (-0.104 m, the upper blob kicked 0.16 m aside within 1 s): 1 is the Newton step
// of two free particles, more overshoots a particle loosely bound to its body (soft, or a long step).
#define OD_FORCE_RATE 1.0
// How much of a sticking pair's slip since it began to stick, beyond this step's own, its friction asks back in a
// step (od_Slip), at steps of OD_FRICTION_STEP or shorter. Against the step's start alone, static friction let what a
// step's last solve left slide: a Stiff sphere resting on another on one pair 5° from the vertical, its friction a
// tenth to a third of its bound, slid 15 µm a step (4 updates; 240 steps a second) and went 0.072 m aside in 10 s.
// Anchored, the slip stays near the step's residual over this (0.5 mm) and the sphere rests (0.011 m aside at 13
// s); 0.1 let the 0.35 m Stiff sphere of the same test rest 0.015 m aside (0.007 at 0.03, 0.009 before); at 0.3 the
// spheres rattled (kinetic 1-2 J) and slid 0.13 m, asked back faster than a stiff member's pairs' friction moves it.
// At longer steps, where the members' rigid step takes friction (od_CoarseFriction), it asks back nothing: there
// (1/24 s) a Jelly slab on one 10 times as dense jolted to 0.116 m/s and a Rubber slab under one 1,000 times as light
// threw it off (docs/contact.md, "Stacks", stop 46).
#define OD_ANCHOR_PULL 0.03
#define OD_HELD_RISE 0.5 // a pair's normal rising more than this presses its lower end down (od_Held)
#define OD_HELD_PUSH 0.2 // of the two largest radii: how much of such a push moves the upper end alone
// The largest ratio of two members' masses for the floor's reaction and rigid step, at steps of OD_CLIMB_TIME or
// longer; at shorter ones it shrinks with the step (od_MemberMasses), never below OD_COMPARABLE_LEAST (reached at
// 150 steps a second).
// That path's pushes act per step (the held push, the floor's projection after the iterations): at 240 steps a
// second slabs 10 times as dense as the lower one slid off it and the drop gained energy (Stiff +14.7 kJ of 5.3 kJ),
// braced they rest. Shrunk to 2.5 there, a 0.35 m sphere on a 0.5 m one (2.9 times its mass, the add-on's 10
// substeps at 24 fps) had none of the rolling resistance, interfaces and patch of comparable members: its two
// pairs held it on the top of a sphere rolling on its floor and the two toppled as one (Flesh 1.445 m aside at 13 s;
// docs/contact.md, "Stacks", stop 40, onepair); with 4 it rests (0.007 m).
#define OD_COMPARABLE 10.0
#define OD_COMPARABLE_LEAST 4.0
// A member rising faster than gravity stops in this time (or in a step, if longer) braces nothing (od_MemberMasses).
// A step's |g| h at 240 steps a second (0.04 m/s) is within a resting member's own motion: it crossed that and
// back, letting its brace go and taking it again, and the slabs above buzzed (docs/contact.md, stacks).
#define OD_CLIMB_TIME (1.0 / 60.0)
// Rolling resistance on the floor (od_Rolls): a member's couple is at most OD_ROLL_REACH times the mean largest
// radius of its particles bearing on the floor times the push down of its comparable pairs, and is updated after
// the first OD_ROLL_UPDATES solves of a step only, then held. Measured on the stacking bench (docs/contact.md, ninth
// round): at 0.3 Jelly spheres rolled off at 60 Hz, at 0.7 and 1 a creature on a like one went 0.14-0.15 m aside
// (0.12 before, 0.135 the bench's bound); updated after every solve (0.7), a Rubber slab under one twice as dense at
// 24 Hz met the iterations' cap (202 solves a step, the couple at its bound) and shook at 0.1 m/s; held after 2
// updates the Jelly spheres rolled off.
#define OD_ROLL_REACH 0.5
#define OD_ROLL_UPDATES 3
// No rolling couple in a step that starts with a member, or one pressing it, moving up or down faster than this
// (m/s; od_Landing): an impact, not a rest. Two 1,000-particle creatures (k = 2e5), one dropped on the other at
// 3.1 m/s (scripts/benchmarks/contact.py's stacked pair), gained 92 kJ at its impact with the couple in 3 of 5 runs
// started 0 to 1 cm apart (none without it); at 1 m/s the Jelly spheres' landing (1.4 m/s) went without it and
// they rolled off at 60 Hz.
#define OD_ROLL_LANDING 2.0
// The longest step with rolling couples between members (od_MemberRolls). At 1/24 s they jolted a Stiff slab on one a
// tenth as dense (0.076 m/s at 8 s, 0.010 without) and the add-on's firm blobs stacked at one step a frame crept
// 0.061 m apart in 4 s (0.036 without; the test's bound 0.05); at 1/60 and 1/240 s the stacking bench held as many
// (docs/contact.md, "Stacks", tenth round).
#define OD_MEMBER_ROLL_STEP (1.0 / 60.0)
// The shortest step whose friction between members takes their rigid step (od_CoarseFriction): at 1/24 s a pair's own
// rate (m/h²) is 6.25 times smaller than at 1/60 s and lagged a Stiff slab's leaning pairs until it slid off; at 1/60 s
// the rigid step let a Stiff slab 3 times as dense as a settled one creep 0.054 m aside and jolt to 0.094 m/s (0.028
// and 0.028 without), two of its pairs' friction opposing each other at ±600 N (docs/contact.md, "Stacks", eleventh
// round).
#define OD_FRICTION_STEP (1.0 / 60.0)
// The fewest pairs a member resting on much heavier ones takes its rigid rates on (od_PerchedRates).
#define OD_PERCHED_PAIRS 3
// How deep (in thicknesses) along its start's centre line a pair between members that began a step overlapping is
// when it is measured along its push direction alone; shallower, along a blend of the two (od_OverlapNormal).
#define OD_OVERLAP_TURN 3.0

od_BodyContactDef od_DefaultBodyContactDef(void)
{
	return (od_BodyContactDef){
		.thickness = 0.005, .friction = 0.5, .exclusionRing = 2, .exclusionScale = 1.5, .inIterations = 1
	};
}

od_Status od_BodyContact_Check(const od_BodyContactDef* def, bool self)
{
	if (!(def->thickness > 0.0) || !isfinite(def->thickness))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "thickness = %g must be finite and > 0", def->thickness);
	}
	if (!(def->friction >= 0.0) || !isfinite(def->friction))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "friction = %g must be finite and >= 0", def->friction);
	}
	if (!self && def->inIterations != 0 && def->inIterations != 1)
	{
		return od_Fail(OD_ERROR_ARGUMENT, "in_iterations = %d must be 0 or 1", def->inIterations);
	}
	if (self && (def->exclusionRing < 0 || def->exclusionRing > 2))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "exclusion_ring = %d must be 0, 1 or 2", def->exclusionRing);
	}
	if (!(def->exclusionScale >= 0.0) || !isfinite(def->exclusionScale))
	{
		return od_Fail(OD_ERROR_ARGUMENT, "exclusion_scale = %g must be finite and >= 0", def->exclusionScale);
	}
	return OD_OK;
}

// Self-contact's forces inside the solves (od_IterateSelf): the near pairs' particles, the response of their
// centres to forces (A⁻¹ between them, the same for x, y and z), and the pairs' normal gaps' response to
// their normal forces. Grown, never shrunk.
typedef struct od_SelfSolve
{
	int n;             // particles the arrays below are sized for
	int* slot;         // n: a particle's place among `particles`, -1 for none
	int* particles;    // n: those of the near pairs
	int count;         // how many
	double* column;    // 3n: three right sides of the global matrix, then their solutions
	double* response;  // count × count
	int responseCapacity;
	double* coupling;  // pairs × pairs
	double* applied;   // 3 per pair: its force (normal and friction) in the last solve
	double* slip;      // 3 per pair: its relative tangential displacement since the step's start
	int pairCapacity;
} od_SelfSolve;

static void od_SelfSolveDestroy(od_SelfSolve* q)
{
	if (q)
	{
		od_Free(q->slot);
		od_Free(q->particles);
		od_Free(q->column);
		od_Free(q->response);
		od_Free(q->coupling);
		od_Free(q->applied);
		od_Free(q->slip);
		od_Free(q);
	}
}

void od_PairScratch_Destroy(od_PairScratch* s)
{
	od_Free(s->body);
	od_Free(s->local);
	od_Free(s->cell);
	od_Free(s->cellStart);
	od_Free(s->sorted);
	od_Free(s->sphere);
	od_Free(s->active);
	od_Free(s->pressing);
	od_Free(s->moved);
	od_Free(s->moment);
	od_Free(s->outward);
	od_Free(s->kept);
	od_Free(s->grounded);
	od_Free(s->held);
	od_Free(s->bearing);
	od_Free(s->rise);
	od_Free(s->supported);
	od_Free(s->climbing);
	od_Free(s->fast);
	od_Free(s->perched);
	od_Free(s->storeys);
	od_Free(s->mass);
	od_Free(s->load);
	od_Free(s->pose);
	od_Free(s->roll);
	od_Free(s->alone);
	od_Free(s->box);
	od_Free(s->couples);
	od_Free(s->interfaces);
	od_Free(s->system);
	od_Free(s->pairs);
	od_Free(s->previous);
	od_SelfSolveDestroy(s->self);
	*s = (od_PairScratch){ 0 };
}

od_Status od_PairScratch_Reserve(od_PairScratch* s, int particles)
{
	if (particles <= s->capacity)
	{
		return OD_OK;
	}
	od_PairScratch_Destroy(s);
	int table = 1;
	while (table < 2 * particles)
	{
		table *= 2;
	}
	s->body = od_Alloc(sizeof(int) * (size_t)particles);
	s->local = od_Alloc(sizeof(int) * (size_t)particles);
	s->cell = od_Alloc(sizeof(int) * (size_t)particles);
	s->sorted = od_Alloc(sizeof(int) * (size_t)particles);
	s->cellStart = od_Alloc(sizeof(int) * ((size_t)table + 1));
	s->sphere = od_Alloc(sizeof(double) * 4 * (size_t)particles);
	s->active = od_Alloc(sizeof(int) * (size_t)particles);
	s->pressing = od_Alloc(sizeof(int) * (size_t)particles);
	s->moved = od_Alloc(sizeof(int) * (size_t)particles);
	s->moment = od_Alloc(sizeof(double) * 9 * (size_t)particles);
	s->outward = od_Alloc(sizeof(double) * 3 * (size_t)particles);
	s->grounded = od_AllocZero((size_t)particles, sizeof(int)); // per member: at most one a particle
	s->held = od_AllocZero((size_t)particles, sizeof(int));
	s->bearing = od_Alloc(sizeof(double) * (size_t)particles);
	s->rise = od_Alloc(sizeof(double) * 2 * (size_t)particles);
	s->supported = od_AllocZero((size_t)particles, sizeof(int));
	s->climbing = od_AllocZero((size_t)particles, sizeof(int));
	s->fast = od_AllocZero((size_t)particles, sizeof(int));
	s->perched = od_AllocZero((size_t)particles, sizeof(int));
	s->storeys = od_Alloc(sizeof(int) * (size_t)particles);
	s->mass = od_Alloc(sizeof(double) * (size_t)particles);
	s->load = od_Alloc(sizeof(double) * (size_t)particles);
	s->pose = od_AllocZero(13 * (size_t)particles, sizeof(double));
	s->roll = od_AllocZero(3 * (size_t)particles, sizeof(double)); // none outside a group's iterations (od_ApplyForces)
	s->kept = od_Alloc(sizeof(double) * 3 * (size_t)particles);
	s->alone = od_Alloc(sizeof(int) * (size_t)particles);
	s->box = od_Alloc(sizeof(double) * 6 * (size_t)particles);
	if (!s->body || !s->local || !s->cell || !s->sorted || !s->cellStart || !s->sphere || !s->active || !s->pressing ||
		!s->moved || !s->moment || !s->outward || !s->grounded || !s->held || !s->bearing || !s->rise || !s->supported ||
		!s->climbing || !s->fast || !s->perched || !s->mass || !s->load || !s->pose || !s->roll || !s->kept ||
		!s->storeys || !s->alone || !s->box)
	{
		od_PairScratch_Destroy(s);
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the contact of %d particles", particles);
	}
	s->capacity = particles;
	s->tableSize = table;
	return OD_OK;
}

static int od_Hash(const od_PairScratch* s, int64_t i, int64_t j, int64_t k)
{
	uint64_t h = (uint64_t)i * 73856093u ^ (uint64_t)j * 19349663u ^ (uint64_t)k * 83492791u;
	return (int)(h & (uint64_t)(s->tableSize - 1));
}

od_Status od_BodyContact_ReserveForces(od_Sim* sim)
{
	if (!sim->contactForce)
	{
		sim->contactForce = od_AllocZero((size_t)3 * sim->graph->n, sizeof(double));
	}
	return sim->contactForce ? OD_OK : od_Fail(OD_ERROR_MEMORY, "out of memory for the contact forces");
}

// Fills the per-particle arrays and sorts the particles into the hashed cells; returns the cell size.
// The grid cell of coordinate x, within +-2^52 so that a neighbour's (+-1) cannot overflow: a NaN or far
// centre (a member gone non-finite within a group's call, refused at its end) was cast to INT64_MIN and the
// neighbour's INT64_MIN - 1 overflowed (UBSan, test_body_contact.py's member gone non-finite).
static int64_t od_Cell(double x, double size)
{
	double cell = floor(x / size);
	return cell > -OD_FAR_CELL ? (cell < OD_FAR_CELL ? (int64_t)cell : (int64_t)OD_FAR_CELL) : -(int64_t)OD_FAR_CELL;
}

static double od_Bin(od_PairScratch* s, od_Sim* const* sims, int count, double thickness, int* total)
{
	int g = 0;
	double largest = 0.0;
	for (int b = 0; b < count; ++b)
	{
		const od_Sim* sim = sims[b];
		for (int i = 0; i < sim->graph->n; ++i, ++g)
		{
			od_Vec3 x0 = od_V3Load(sim->previous.x + 3 * i), x1 = od_V3Load(sim->state.x + 3 * i);
			double r = od_SkinPair_Reach(sim, i) + 0.5 * (od_Length(od_Sub(x1, x0)) + thickness);
			od_V3Store(s->sphere + 4 * g, od_Scale(0.5, od_Add(x0, x1)));
			s->sphere[4 * g + 3] = r;
			s->body[g] = b;
			s->local[g] = i;
			largest = fmax(largest, r);
		}
	}
	*total = g;
	double size = 2.0 * largest;
	memset(s->cellStart, 0, sizeof(int) * ((size_t)s->tableSize + 1));
	for (int p = 0; p < g; ++p)
	{
		const double* c = s->sphere + 4 * p;
		s->cell[p] = od_Hash(s, od_Cell(c[0], size), od_Cell(c[1], size), od_Cell(c[2], size));
		s->cellStart[s->cell[p] + 1]++;
	}
	for (int t = 0; t < s->tableSize; ++t)
	{
		s->cellStart[t + 1] += s->cellStart[t];
	}
	for (int p = 0; p < g; ++p)
	{
		s->sorted[s->cellStart[s->cell[p]]++] = p;
	}
	for (int t = s->tableSize; t > 0; --t) // the fill advanced each start to the next one's
	{
		s->cellStart[t] = s->cellStart[t - 1];
	}
	s->cellStart[0] = 0;
	return size;
}

static bool od_Adjacent(const od_Graph* graph, int i, int j)
{
	for (int k = graph->adjStart[i]; k < graph->adjStart[i + 1]; ++k)
	{
		if (graph->adj[k] == j)
		{
			return true;
		}
	}
	return false;
}

// Whether particles i and j of one simulation are excluded from its self-contact.
static bool od_Excluded(const od_Sim* sim, int i, int j)
{
	const od_Graph* graph = sim->graph;
	const od_BodyContactDef* d = &sim->selfDef;
	double reach = od_ParticleReach(sim, i) + od_ParticleReach(sim, j);
	if (od_Length(od_Sub(od_V3Load(graph->centers + 3 * i), od_V3Load(graph->centers + 3 * j))) <
		d->exclusionScale * reach)
	{
		return true;
	}
	if (d->exclusionRing >= 1 && od_Adjacent(graph, i, j))
	{
		return true;
	}
	for (int k = graph->adjStart[i]; d->exclusionRing >= 2 && k < graph->adjStart[i + 1]; ++k)
	{
		if (od_Adjacent(graph, graph->adj[k], j))
		{
			return true;
		}
	}
	return false;
}

static od_Status od_AddPair(od_PairScratch* s, int a, int b)
{
	if (s->pairCount == s->pairCapacity)
	{
		int capacity = s->pairCapacity ? 2 * s->pairCapacity : 256;
		od_ContactPair* grown = od_Realloc(s->pairs, sizeof *grown * (size_t)capacity);
		if (!grown)
		{
			return od_Fail(OD_ERROR_MEMORY, "out of memory for %d contact pairs", capacity);
		}
		s->pairs = grown;
		s->pairCapacity = capacity;
	}
	s->pairs[s->pairCount++] = (od_ContactPair){ .a = a, .b = b };
	return OD_OK;
}

// Whether particle i of a and j of b, two members whose goals carry the rest, have goal centres closer than
// `scale` times the sum of their largest reaches (docs/contact.md, "Members that overlap at rest"): the animation
// puts them together, so their contact is the animation's, not the simulation's. Measured at the goals of the step
// (placed between frames, od_Goals_Place), so the exclusion follows the animation.
static bool od_TogetherAtGoals(const od_Sim* a, int i, const od_Sim* b, int j, double scale)
{
	if (!od_Goals_CarryRest(a) || !od_Goals_CarryRest(b))
	{
		return false;
	}
	double reach = od_SkinPair_Reach(a, i) + od_SkinPair_Reach(b, j);
	return od_Length(od_Sub(od_V3Load(a->goals.x + 3 * i), od_V3Load(b->goals.x + 3 * j))) < scale * reach;
}

// Whether particles p < q may collide (bounding spheres overlap, not excluded: within one body by its
// self-contact's exclusion, between two by `between`'s at their goals).
static bool od_Candidate(const od_PairScratch* s, od_Sim* const* sims, int p, int q, const od_BodyContactDef* between)
{
	const double *cp = s->sphere + 4 * p, *cq = s->sphere + 4 * q;
	double r = cp[3] + cq[3];
	od_Vec3 d = od_Sub(od_V3Load(cq), od_V3Load(cp));
	if (od_Dot(d, d) >= r * r)
	{
		return false;
	}
	const od_Sim *sim = sims[s->body[p]], *other = sims[s->body[q]];
	if (sim != other)
	{
		return !od_TogetherAtGoals(sim, s->local[p], other, s->local[q], between->exclusionScale);
	}
	return sim->selfContact && !od_Excluded(sim, s->local[p], s->local[q]);
}

// The candidate pairs: each particle against those of the 27 cells about its own with a larger index (each
// bucket of the table once: distinct cells may share one).
static od_Status od_FindPairs(od_PairScratch* s, od_Sim* const* sims, int total, double size,
							 const od_BodyContactDef* between)
{
	s->pairCount = 0;
	for (int p = 0; p < total; ++p)
	{
		const double* c = s->sphere + 4 * p;
		int64_t base[3] = { od_Cell(c[0], size), od_Cell(c[1], size), od_Cell(c[2], size) };
		int seen[27], seenCount = 0;
		for (int n = 0; n < 27; ++n)
		{
			int t = od_Hash(s, base[0] + n % 3 - 1, base[1] + (n / 3) % 3 - 1, base[2] + n / 9 - 1), dup = 0;
			for (int k = 0; k < seenCount; ++k)
			{
				dup |= seen[k] == t;
			}
			if (dup)
			{
				continue;
			}
			seen[seenCount++] = t;
			for (int k = s->cellStart[t]; k < s->cellStart[t + 1]; ++k)
			{
				int q = s->sorted[k];
				od_Status status = q > p && od_Candidate(s, sims, p, q, between) ? od_AddPair(s, p, q) : OD_OK;
				if (status != OD_OK)
				{
					return status;
				}
			}
		}
	}
	return OD_OK;
}

// One end of a pair: its simulation, index, mass and start and end centres.
typedef struct od_End
{
	od_Sim* sim;
	int i;
	double mass;
	od_Vec3 x0, x1;
} od_End;

static od_End od_EndOf(const od_PairScratch* s, od_Sim* const* sims, int p)
{
	od_Sim* sim = sims[s->body[p]];
	int i = s->local[p];
	return (od_End){ sim, i, sim->def.density * sim->graph->volumes[i], od_V3Load(sim->previous.x + 3 * i),
					 od_V3Load(sim->state.x + 3 * i) };
}

// Moves the two ends apart by `by` along n, a's share by b's mass fraction (momentum kept; an immovable end,
// od_Brace, neither moves nor is written), at once: the passes are Gauss-Seidel. (Jacobi, each particle moved
// by the mean of its pairs' pushes, let a 20 m/s body through another and lost momentum, as a particle's pairs
// share its push unequally.) Up to `held` of it moves the upper end alone (od_Held; 0 for none): b where n
// rises, else a.
static void od_Separate(od_End* a, od_End* b, od_Vec3 n, double by, double held)
{
	double share = isinf(b->mass) ? 1.0 : b->mass / (a->mass + b->mass);
	double alone = copysign(fmin(fabs(by), held), by), split = by - alone;
	bool rises = n.z > 0.0;
	a->x1 = od_MulAdd(a->x1, -share * split - (rises ? 0.0 : alone), n);
	b->x1 = od_MulAdd(b->x1, (1.0 - share) * split + (rises ? alone : 0.0), n);
	if (!isinf(a->mass))
	{
		od_V3Store(a->sim->state.x + 3 * a->i, a->x1);
	}
	if (!isinf(b->mass))
	{
		od_V3Store(b->sim->state.x + 3 * b->i, b->x1);
	}
}

// The smallest distance of the relative path d0 -> d1 from zero.
static double od_ClosestApproach(od_Vec3 d0, od_Vec3 d1)
{
	od_Vec3 e = od_Sub(d1, d0);
	double ee = od_Dot(e, e), s = ee > 0.0 ? fmin(fmax(-od_Dot(d0, e) / ee, 0.0), 1.0) : 0.0;
	return od_Length(od_MulAdd(d0, s, e));
}

// How much particle i is on its body's surface, outwards: R_i (X̄_i - mean of its neighbours' X̄_j) over their
// mean distance; near zero inside the body, up to about 1 on a face.
static od_Vec3 od_Outward(const od_Sim* sim, int i)
{
	const od_Graph* g = sim->graph;
	od_Vec3 ci = od_V3Load(g->centers + 3 * i), sum = od_V3(0, 0, 0);
	double spread = 0.0;
	for (int k = g->adjStart[i]; k < g->adjStart[i + 1]; ++k)
	{
		od_Vec3 d = od_Sub(ci, od_V3Load(g->centers + 3 * g->adj[k]));
		sum = od_Add(sum, d);
		spread += od_Length(d);
	}
	od_Mat3 r = od_M3Load(sim->state.R + 9 * i);
	return spread > 0.0 ? od_Scale(1.0 / spread, od_M3MulV(&r, sum)) : sum;
}

// The push direction of a pair along centre line c (unit, a to b): c turned towards the bodies' surface
// normals there (a's outward minus b's), so that two flat faces push each other straight apart. Along c
// alone, the particles of a face are bumps: a body on another rolled off them sideways (a 0.6 m bar dropped
// on a like one slid 0.5 m off it at any friction).
static od_Vec3 od_PushDirection(const od_PairScratch* s, const od_ContactPair* pair, od_Vec3 c)
{
	od_Vec3 m = od_Add(c, od_Sub(od_V3Load(s->outward + 3 * pair->a), od_V3Load(s->outward + 3 * pair->b)));
	double length = od_Length(m);
	return length > 0.0 && od_Dot(m, c) > 0.5 * length ? od_Scale(1.0 / length, m) : c;
}

// The normal of a pair between members that began the step overlapping along its start's centre line c0 (unit) by
// `overlap`: the push direction of its centre line c1 now, turned back towards c0 by how far the overlap is from
// OD_OVERLAP_TURN thicknesses, so that the normal is continuous in the state where the pair turns from apart (measured
// along c0) to overlapping. Measured along the push direction alone from the least overlap, a corner particle of a
// light Jelly slab perched on one 1,000 times as dense (24 steps a second) flapped ±5.9 mm every other step: 0.3 mm
// into the other along c0 it read 6.9 mm deep along its push direction (24° off c0: the two flat ellipsoids' overlap
// that is not there) and was lifted 6 mm, the next step it began apart and, measured along c0, read a 15 mm gap and
// fell back (docs/contact.md, "Stop 49").
static od_Vec3 od_OverlapNormal(const od_PairScratch* s, const od_ContactPair* pair, od_Vec3 c0, double overlap,
								od_Vec3 c1, double thickness)
{
	od_Vec3 push = od_PushDirection(s, pair, c1);
	double turn = OD_OVERLAP_TURN * thickness;
	double w = overlap < turn ? overlap / turn : 1.0;
	od_Vec3 m = od_MulAdd(od_Scale(w, push), 1.0 - w, c0);
	double length = od_Length(m);
	return length > 0.0 ? od_Scale(1.0 / length, m) : push;
}

// Where a pair stands (see the top of the file): the centre line c along which it is measured, how deep it
// is within reach (> 0: in contact), how deep it may stay (a pair that began overlapping leaves at the
// recovery speed), whether its path never came within reach (a pair apart at the start that passed by), and
// whether it is pushed along c itself (od_PushAlong) rather than along od_PushDirection(c).
typedef struct od_PairState
{
	od_Vec3 c;
	double depth, allowed;
	bool passed, along;
} od_PairState;

// Whether sim steps OD_MEMBER_ROLL_STEP or shorter (a group's members step alike).
static bool od_ShortStep(const od_Sim* sim)
{
	return sim->def.dt <= OD_MEMBER_ROLL_STEP * (1.0 + 1e-9);
}

// Whether a pair is its members' only contact at the last update (its interface's one pair, od_Interfaces).
static bool od_Single(const od_PairScratch* s, const od_ContactPair* pair)
{
	int e = pair->interface, ma = s->body[pair->a], mb = s->body[pair->b];
	const od_Interface* f = e >= 0 && e < s->interfaceCount ? &s->interfaces[e] : NULL;
	return f && f->count == 1 && ((f->lower == ma && f->upper == mb) || (f->lower == mb && f->upper == ma));
}

// Whether a pair is pushed along the line it is measured on: a skin pair (its separating axis), and at steps of
// OD_MEMBER_ROLL_STEP or shorter a pair apart at the step's start (measured along its start's centre line c) that is
// its two members' only contact (od_Single: no face whose pairs od_PushDirection pushes straight apart). Such a pair's
// constraint in the step is the plane across c; pushed along od_PushDirection(c), off c, its force did work along
// that plane: a default Rubber Suzanne resting on another on a single such pair (c 4.4° off the push, the two
// ellipsoids' supports along c growing as the pair slid) rose 3.0 cm in 9 s at rest, its fastest particle at 0.010
// m/s; pushed along c it loses energy (docs/contact.md, "Stacks", stop 40). Every pair apart at the start so pushed,
// a Jelly Suzanne dropped on another slid off the lower's head (2.5 m aside, 0.75 before) and at 1/60 s two
// 1,000-particle creatures dropped one on the other gained 51 kJ over their 4.5 kJ in a step after the landing (why
// is not found); at 1/24 s two Jelly spheres stacked on a settled one rolled off (0.65 m aside at 13 s, 0.25 before).
static bool od_PushAlong(const od_PairScratch* s, const od_ContactPair* pair, const od_End* a, const od_End* b,
						const od_BodyContactDef* d, bool apart, bool skin)
{
	return skin || (apart && a->sim != b->sim && d->inIterations && od_ShortStep(a->sim) && od_Single(s, pair));
}

// How far a pair that began overlapping may leave it in a step (the recovery speed, contact.c); none against
// an immovable end (od_Brace), which would throw the heavy end off it.
static double od_Recovery(const od_End* a, const od_End* b)
{
	return isinf(a->mass) || isinf(b->mass) ? 0.0 : od_RecoveryLimit(a->sim);
}

// The sum of two ends' largest reaches: their ellipsoids', or between bodies with a contact skin the larger of
// each end's skin and ellipsoid (skin_pairs.c).
static double od_Reaches(const od_End* a, const od_End* b)
{
	bool skin = od_SkinPair_Used(a->sim, b->sim);
	return skin ? od_SkinPair_Reach(a->sim, a->i) + od_SkinPair_Reach(b->sim, b->i)
				: od_ParticleReach(a->sim, a->i) + od_ParticleReach(b->sim, b->i);
}

// How far the two ends' shapes reach towards each other along unit c (a to b): their ellipsoids (the cached
// moments), or between bodies a member's skin points (skin_pairs.c).
static double od_ShapeReaches(const od_PairScratch* s, const od_ContactPair* pair, const od_End* a, const od_End* b,
							  od_Vec3 c)
{
	od_Mat3 ma = od_M3Load(s->moment + 9 * pair->a), mb = od_M3Load(s->moment + 9 * pair->b);
	if (!od_SkinPair_Used(a->sim, b->sim))
	{
		return od_Support(&ma, c) + od_Support(&mb, c);
	}
	return od_SkinPair_Support(a->sim, a->i, &ma, c) + od_SkinPair_Support(b->sim, b->i, &mb, od_Scale(-1.0, c));
}

// A skin pair's normal (its centre line c, b's centre at d from a's; skin_pairs.c), from c, its last normal, its
// push direction and the two particles' outward directions; in a group's iterations after od_GatherNear, from c
// and its last normal alone (re-aimed at every update as the ellipsoids' pairs are: held from the gather on, the
// add-on tests' blob dropped on a blob went 1.9 % of its size into it, apart by 0.1-0.3 cm re-aimed; the full
// search at every update cost the bars at rest 5.3 ms a step, 3.3 held). `settle`: q->settle (skin_pairs.h).
static od_Vec3 od_SkinNormal(const od_PairScratch* s, const od_ContactPair* pair, const od_End* a, const od_End* b,
							 od_Vec3 d, od_Vec3 c, double thickness, bool settle)
{
	od_Mat3 ma = od_M3Load(s->moment + 9 * pair->a), mb = od_M3Load(s->moment + 9 * pair->b);
	od_Vec3 directions[5] = { c, od_V3Load(pair->n), od_PushDirection(s, pair, c), od_V3Load(s->outward + 3 * pair->a),
							  od_Scale(-1.0, od_V3Load(s->outward + 3 * pair->b)) };
	od_SkinPair q = { a->sim, b->sim, a->i, b->i, &ma, &mb, d, thickness, settle };
	return od_SkinPair_Normal(&q, directions, s->warmNormals ? 2 : 5);
}

static od_PairState od_MeasureAlong(const od_PairScratch* s, const od_ContactPair* pair, const od_End* a,
									const od_End* b, const od_BodyContactDef* d, bool settle)
{
	od_Vec3 d0 = od_Sub(b->x0, a->x0), d1 = od_Sub(b->x1, a->x1);
	double l0 = od_Length(d0), l1 = od_Length(d1);
	od_PairState p = { .c = l0 > 0.0 ? od_Scale(1.0 / l0, d0) : od_V3(0, 0, 1) };
	double largest = od_Reaches(a, b);
	if (l0 >= largest && od_ClosestApproach(d0, d1) >= largest + d->thickness) // far: its spheres never met
	{
		p.passed = true;
		return p;
	}
	bool skin = od_SkinPair_Used(a->sim, b->sim);
	p.c = skin ? od_SkinNormal(s, pair, a, b, d0, p.c, d->thickness, settle) : p.c;
	double supports = od_ShapeReaches(s, pair, a, b, p.c);
	bool apart = l0 > 0.0 && (skin ? od_Dot(p.c, d0) : l0) >= supports;
	if (!apart && l1 > 0.0)
	{
		od_Vec3 c0 = p.c;
		p.c = od_Scale(1.0 / l1, d1);
		// Two bodies that began overlapping: measured along the push direction, which the bodies' surfaces
		// make the same for the pairs of a face; along each pair's own line, a particle sandwiched between
		// pairs of different lines was pushed by all (bars started 10 cm into each other: fastest particle
		// 3.0 m/s, 1.2 m/s along the push direction; 1.3 turned back towards c0 while barely overlapping).
		bool between = a->sim != b->sim && d->inIterations;
		p.c = between && !skin && l0 > 0.0 ? od_OverlapNormal(s, pair, c0, supports - l0, p.c, d->thickness)
			  : between ? od_PushDirection(s, pair, p.c)
						: p.c;
		p.c = skin ? od_SkinNormal(s, pair, a, b, d1, p.c, d->thickness, settle) : p.c;
		supports = od_ShapeReaches(s, pair, a, b, p.c);
	}
	double reach = supports + d->thickness;
	p.depth = reach - od_Dot(p.c, d1);
	// Passed: apart at the start, overlapping along c now, but the centres never within reach of each other (they
	// slid past). A skin pair's c is its separating axis, not its centre line, so its centres' distance says
	// nothing of its overlap along c: two 0.6 m Rubber spheres at rest on each other on their skins had pairs
	// overlapping along c yet passed, their forces dropped and taken up every other update (a particle jumping 4-6
	// mm, 100 iterations a step under the preset's tolerance, 8.4 ms a step); counted in contact, 2 (0.95 ms).
	p.passed = apart && p.depth > 0.0 && !skin && od_ClosestApproach(d0, d1) >= reach;
	p.along = od_PushAlong(s, pair, a, b, d, apart, skin);
	p.allowed = apart ? 0.0
					  : fmax(reach - (a->sim != b->sim && d->inIterations ? od_Dot(p.c, d0) : l0) - od_Recovery(a, b), 0.0);
	return p;
}

// A pair's state now: its shapes' overlap along its normal, how much of it a step may leave, whether it passed.
// A skin pair carrying no force found apart along a direction that settles its search (skin_pairs.h) is apart; one
// in contact along it is measured again with the whole search, which its push needs (settled there too, the
// projection pushed the skins of the skin_pairs.py spheres at 10 m/s 5.2 cm apart, not 1.0); one carrying a force
// keeps the whole search for its force's normal (settled, the bars at rest 0.8 cm apart, not 0.6). The add-on's two
// Suzannes at rest on their skins, 10 steps a frame: 58 -> 42 ms a frame outside the iterations (the gather and the
// projection), -> 25 ms in them too, the same iterations and the same bits in that scene.
static od_PairState od_Measure(const od_PairScratch* s, const od_ContactPair* pair, const od_End* a, const od_End* b,
								const od_BodyContactDef* d)
{
	bool settle = od_SkinPair_Used(a->sim, b->sim) && (!s->warmNormals || !(pair->force > 0.0));
	od_PairState p = od_MeasureAlong(s, pair, a, b, d, settle);
	return settle && !p.passed && p.depth > 0.0 ? od_MeasureAlong(s, pair, a, b, d, false) : p;
}

// How many particles the group's members have together (the per-particle scratch arrays' length).
static int od_GroupParticles(od_Sim* const* sims, int count)
{
	int total = 0;
	for (int b = 0; b < count; ++b)
	{
		total += sims[b]->graph->n;
	}
	return total;
}

// Every particle's ellipsoid (od_ParticleMoment) and outward direction (od_Outward) at its current rotation,
// for the measures of its pairs: once per particle, not per pair.
static void od_CacheMoments(od_PairScratch* s, od_Sim* const* sims, int count)
{
	for (int b = 0, g = 0; b < count; ++b)
	{
		for (int i = 0; i < sims[b]->graph->n; ++i, ++g)
		{
			od_Mat3 m = od_ParticleMoment(sims[b], i);
			od_M3Store(s->moment + 9 * g, &m);
			od_V3Store(s->outward + 3 * g, od_Outward(sims[b], i));
		}
	}
}

// Whether a pair's normal rises towards its lighter member by more than OD_HELD_RISE: the lighter rests on it.
static bool od_LightOnTop(const od_PairScratch* s, const od_ContactPair* pair)
{
	double ma = s->mass[s->body[pair->a]], mb = s->mass[s->body[pair->b]];
	return (ma > mb ? pair->n[2] : -pair->n[2]) > OD_HELD_RISE;
}

// Whether a pair's two members' masses are within s->comparable of each other (od_MemberMasses): only
// such pairs press a member onto its floor's reaction (od_FloorReaction), take the members' rigid step
// (od_Coarse) and hold a push (od_Held). Beyond it the light member was squeezed out from under the heavy one
// and the drop gained energy (the centres' kinetic and potential energy above its start: a Jelly slab under one
// 100 times as dense +31 kJ of 35, Rubber and Stiff at 1,000 times +2.9-3.5 kJ, at 1e6 times +0.8-10.5 MJ;
// none before the reaction), so a much heavier member resting on a light one on the floor is held by bracing
// the light one instead (od_Braced).
//
// At steps shorter than OD_CLIMB_TIME, where the ratio shrinks (od_MemberMasses), a pair whose lighter end rests on
// the heavier one (its normal rising towards the lighter by more than OD_HELD_RISE) is comparable at any ratio: the
// shrink was for heavy members on light ones (a Stiff slab 10 times as dense slid off at 240 steps a second). Left
// out, a 0.3 m Flesh sphere on a 0.5 m one (4.6 times its mass, the add-on's 240 steps a second) stood on plain
// pairs on a sphere free to roll on its floor and the two toppled as one (1.403 m aside at 13 s; 0.004 m now);
// at longer steps light slabs on ones 1,000 times as dense so taken shook (Stiff 0.086 m/s at 24 steps a second;
// docs/contact.md, "Stacks", stop 42).
static bool od_Comparable(const od_PairScratch* s, const od_ContactPair* pair)
{
	double ma = s->mass[s->body[pair->a]], mb = s->mass[s->body[pair->b]];
	return fmax(ma, mb) <= s->comparable * fmin(ma, mb) || (s->comparable < OD_COMPARABLE && od_LightOnTop(s, pair));
}

// The lighter member of a pair between members that are not comparable (od_Comparable) whose normal rises towards
// it (od_LightOnTop): it rests on the much heavier one; else -1.
static int od_Perched(const od_PairScratch* s, const od_ContactPair* pair)
{
	int ma = s->body[pair->a], mb = s->body[pair->b];
	return ma != mb && !od_Comparable(s, pair) && od_LightOnTop(s, pair) ? (s->mass[ma] > s->mass[mb] ? mb : ma) : -1;
}

// The inverse of a symmetric 3 × 3 matrix a (its adjugate over its determinant), zero where a is singular.
static od_Mat3 od_SymmetricInverse(const od_Mat3* a)
{
	od_Vec3 r0 = od_V3(a->m[0], a->m[1], a->m[2]), r1 = od_V3(a->m[3], a->m[4], a->m[5]);
	od_Vec3 r2 = od_V3(a->m[6], a->m[7], a->m[8]);
	od_Vec3 c0 = od_Cross(r1, r2), c1 = od_Cross(r2, r0), c2 = od_Cross(r0, r1);
	double det = od_Dot(r0, c0);
	if (!(fabs(det) > 0.0) || !isfinite(det))
	{
		return od_M3Zero();
	}
	return (od_Mat3){ { c0.x / det, c1.x / det, c2.x / det, c0.y / det, c1.y / det, c2.y / det, c0.z / det,
						c1.z / det, c2.z / det } };
}

// The mass-weighted mean over member b's particles of a field of 3-vectors (positions: its centre of mass;
// velocities: its mean velocity), with s->mass[b] its mass.
static od_Vec3 od_MemberMean(const od_PairScratch* s, const od_Sim* sim, int b, const double* field)
{
	od_Vec3 mean = od_V3(0, 0, 0);
	for (int i = 0; i < sim->graph->n; ++i)
	{
		mean = od_MulAdd(mean, sim->def.density * sim->graph->volumes[i] / s->mass[b], od_V3Load(field + 3 * i));
	}
	return mean;
}

// Member b's centre of mass at the step's start and the inverse of its particles' inertia about it (s->pose), for
// its turn (od_Turn) and the floor's rolling couple on it (od_ApplyRolls).
static void od_Pose(od_PairScratch* s, const od_Sim* sim, int b)
{
	const double* x = sim->previous.x;
	od_Vec3 centre = od_MemberMean(s, sim, b, x);
	od_Mat3 inertia = od_M3Zero(), identity = od_M3Identity();
	double height = 0.0;
	for (int i = 0; i < sim->graph->n; ++i)
	{
		double m = sim->def.density * sim->graph->volumes[i];
		od_Vec3 r = od_Sub(od_V3Load(x + 3 * i), centre);
		od_M3AddScaled(&inertia, m * od_Dot(r, r), &identity);
		od_M3AddOuter(&inertia, -m, r, r);
		height += m * r.z * r.z;
	}
	od_Mat3 inverse = od_SymmetricInverse(&inertia);
	od_V3Store(s->pose + 13 * b, centre);
	od_M3Store(s->pose + 13 * b + 3, &inverse);
	s->pose[13 * b + 12] = height;
}

// The ratio of masses beyond which members are not comparable this step (s->comparable, OD_COMPARABLE), each
// member's mass (s->mass) and whether it rises at the step's start faster than its gravity takes away in a
// step or OD_CLIMB_TIME, the longer (s->climbing: its mean vertical velocity above |g| max(h, OD_CLIMB_TIME)),
// once a step. A rising member (popped up by its floor, bouncing) braces nothing (od_Supports): braced, a light
// slab popped up by the floor threw a slab 100 times as dense resting on it (+20 kJ at 240 steps a second).
static void od_MemberMasses(od_PairScratch* s, od_Sim* const* sims, int count)
{
	for (int b = 0; b < count; ++b)
	{
		const od_Sim* sim = sims[b];
		double up = 0.0;
		s->mass[b] = 0.0;
		for (int i = 0; i < sim->graph->n; ++i)
		{
			double m = sim->def.density * sim->graph->volumes[i];
			s->mass[b] += m;
			up += m * sim->state.v[3 * i + 2];
		}
		const double* g = sim->def.gravity;
		double stop = sim->def.dt > OD_CLIMB_TIME ? sim->def.dt : OD_CLIMB_TIME;
		s->climbing[b] = up / s->mass[b] > sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) * stop;
		s->fast[b] = fabs(up / s->mass[b]) > OD_ROLL_LANDING;
		od_Pose(s, sim, b);
	}
	double share = count > 0 ? sims[0]->def.dt / OD_CLIMB_TIME : 1.0; // a group's members step alike
	s->comparable = fmax(OD_COMPARABLE * (share < 1.0 ? share : 1.0), OD_COMPARABLE_LEAST);
}

// Whether member m rests on the members its pairs counted in s->rise lead to (od_Rise): their normals' mean
// rises towards it by more than OD_HELD_RISE.
static bool od_Rests(const od_PairScratch* s, int m)
{
	return s->rise[2 * m] > OD_HELD_RISE * s->rise[2 * m + 1];
}

// Whether member `lower` may brace member `upper` (od_Braced): it is supported (on its floor or on supported
// members, od_Supports) and the lighter, beyond OD_COMPARABLE. (A heavy member on the floor under a light one
// moves little when split by mass; braced too, a light Rubber slab on one 1,000 times as dense shook more:
// 0.053 m/s, 0.044 split.)
static bool od_Bears(const od_PairScratch* s, int lower, int upper)
{
	return s->supported[lower] > 0 && s->comparable * s->mass[lower] < s->mass[upper];
}

// Shock propagation (Guendelman, Bridson and Fedkiw 2003): a supported member stands immovable and still
// (od_Brace) to every pair with a member beyond OD_COMPARABLE of its mass that rests on it (od_Bears,
// od_Supports), in the solves (the force acts on the upper end alone, at that end's rate) and in the
// projection (the upper end takes the whole push, at most back to where it started, and the friction). Split
// by mass, a heavy member pushed a light one on the floor through it in the solves and the floor lifted it back
// into the heavy one after them, deeper every step (docs/contact.md, stacks). Which end: 'a', 'b' or 0 (none).
static char od_Braced(const od_PairScratch* s, const od_ContactPair* pair)
{
	int ma = s->body[pair->a], mb = s->body[pair->b];
	return ma == mb ? 0 : od_Bears(s, ma, mb) && od_Rests(s, mb) ? 'a' : od_Bears(s, mb, ma) && od_Rests(s, ma) ? 'b' : 0;
}

// The end od_Braced names made immovable and still: its mass infinite, where it stood at the step's start, so
// that its own motion in the step, which nothing opposes, never throws the heavy end (braced where it was, a
// Rubber slab 1e6 times as dense on a light one at 240 steps a second gained 2.6 GJ; od_Measure then allows
// no recovery against it and od_ResolvePair caps the push, so the heavy end is stopped, never thrown).
static void od_Brace(const od_PairScratch* s, const od_ContactPair* pair, od_End* a, od_End* b)
{
	char braced = od_Braced(s, pair);
	*a = braced == 'a' ? (od_End){ a->sim, a->i, INFINITY, a->x0, a->x0 } : *a;
	*b = braced == 'b' ? (od_End){ b->sim, b->i, INFINITY, b->x0, b->x0 } : *b;
}

// How much of a push along n (a to b) moves only its upper end (od_Separate): where it presses the lower end
// down (n rising by more than OD_HELD_RISE) onto the floor that holds its member in the iterations
// (od_FloorReaction), up to OD_HELD_PUSH of the sum of the two particles' largest radii; else 0 (split by
// mass). Split, the lower end's share went into the floor and the floor lifted it back after the iterations,
// every step: a Stiff slab under one 10 times as dense shook at 0.095 m/s (0.007 now) and the upper two of
// three Rubber slabs at rest crept sideways at 0.9-1.1 mm/s (0.08-0.16 now). Held whole, a deep push at an
// impact threw the heavy end up: a Rubber slab 100 times as dense dropped 0.25 m gained 968 J over its start
// (of 84 kJ); held up to 0.05 of the radii, the three slabs crept at 1.2-1.6 mm/s.
static double od_Held(const od_PairScratch* s, const od_ContactPair* pair, const od_End* a, const od_End* b, od_Vec3 n)
{
	bool pressed = (s->held[s->body[pair->a]] > 0 && n.z > OD_HELD_RISE) ||
				   (s->held[s->body[pair->b]] > 0 && n.z < -OD_HELD_RISE);
	return a->sim != b->sim && pressed && od_Comparable(s, pair)
			   ? OD_HELD_PUSH * (od_ParticleReach(a->sim, a->i) + od_ParticleReach(b->sim, b->i))
			   : 0.0;
}

// One pass over one pair: pushes it apart as far as it is in contact (see the top of the file).
static bool od_ResolvePair(const od_PairScratch* s, od_ContactPair* pair, od_End* a, od_End* b,
						   const od_BodyContactDef* d)
{
	od_Brace(s, pair, a, b);
	od_PairState p = od_Measure(s, pair, a, b, d);
	if (p.depth <= 0.0 || p.passed)
	{
		return false;
	}
	double push = fmax(p.depth - p.allowed, 0.0);
	od_Vec3 n = p.along ? p.c : od_PushDirection(s, pair, p.c);
	// Against an immovable end (od_Brace), at most back to where the other end started along n: the push along
	// n, not along the measured line, and several pairs' pushes went beyond (the Rubber slab 1e6 times as dense
	// at 240 steps a second gained 86 MJ).
	push = isinf(a->mass) ? fmin(push, fmax(-od_Dot(n, od_Sub(b->x1, b->x0)), 0.0))
		   : isinf(b->mass) ? fmin(push, fmax(od_Dot(n, od_Sub(a->x1, a->x0)), 0.0))
							: push;
	od_Separate(a, b, n, push, od_Held(s, pair, a, b, n));
	pair->push += push;
	od_V3Store(pair->n, n);
	return true;
}

// Whether the group's friction between members takes their rigid step (od_CoarseFriction): at steps longer than
// OD_FRICTION_STEP (a group's members step alike).
static bool od_FrictionStep(od_Sim* const* sims)
{
	return sims[0]->def.dt > OD_FRICTION_STEP * (1.0 + 1e-9);
}

// The frame a pair's slip is measured in: how far its end a's particle turns over the step as its angular velocity
// at the step's start turns it, where the pair carried a force into the step (pair->resting) between two members.
// Measured in world coordinates, a stack tilted or rolled as one read the turn times the pair's centres' distance as
// a slip, and friction, warm started from step to step, pulled the upper member back to where it had been in the
// world: a Stiff slab on one its goals tilted 15 degrees crept 3.6-4.6 cm on it (0.1-0.4 cm now; docs/contact.md,
// "Stacks", stop 47). Turned with the particle's rotation within the iterations instead, the measure took the solves'
// transients (Jelly slabs 10:1 at 24 steps a second rocked at 0.16 m/s); with its member's rigid turn, a light Jelly
// slab on one 1,000 times as dense landed 6 cm aside and crept. None at an impact (a pair new to the step: its
// particles' spins are the impact's; a Suzanne landing on another at 240 steps a second slid 0.4 m aside, still
// moving at 3 s), for self-contact (as its forces, od_IterateSelf), where an end is braced immovable (od_Brace), and
// at longer steps than OD_FRICTION_STEP (od_FrictionStep), where friction takes the members' rigid step and asks
// back no anchor: there a Jelly particle's turn in a step is mostly its wobble (Jelly slabs 10:1 rocked at 0.059
// m/s).
static od_Mat3 od_Turning(const od_ContactPair* pair, const od_End* a, const od_End* b)
{
	bool turns = pair->resting && a->sim != b->sim && !isinf(a->mass) && !od_FrictionStep(&a->sim);
	return turns ? od_M3ExpSkew(od_Scale(a->sim->def.dt, od_V3Load(a->sim->state.omega + 3 * a->i)))
				 : od_M3Identity();
}

// How far a pair's end a's particle turned over the step that ended (R_a R_a⁽¹⁾ᵀ; none where it is braced).
static od_Mat3 od_Turned(const od_End* a)
{
	od_Mat3 now = od_M3Load(a->sim->state.R + 9 * a->i), start = od_M3Load(a->sim->previous.R + 9 * a->i);
	return isinf(a->mass) ? od_M3Identity() : od_M3MulNT(&now, &start);
}

// How far a pair's end b moved from its end a since the step's start, in its frame (od_Turning): where b is from a
// now less where it was, turned as a turns. Two members that turn together read no slip.
static od_Vec3 od_Displacement(const od_ContactPair* pair, const od_End* a, const od_End* b)
{
	od_Mat3 turned = od_Turning(pair, a, b);
	return od_Sub(od_Sub(b->x1, a->x1), od_M3MulV(&turned, od_Sub(b->x0, a->x0)));
}

// Coulomb friction of a pair that was pushed: its relative tangential displacement cut by μ times the push.
static void od_PairFriction(const od_PairScratch* s, const od_ContactPair* pair, od_End* a, od_End* b, double mu)
{
	od_Vec3 n = od_V3Load(pair->n);
	od_Brace(s, pair, a, b);
	od_Vec3 rel = od_Displacement(pair, a, b);
	od_Vec3 slip = od_MulAdd(rel, -od_Dot(rel, n), n);
	double length = od_Length(slip), cut = 1.0 - od_CoulombKeep(length, mu * pair->push);
	if (length > 0.0 && cut > 0.0)
	{
		od_Separate(a, b, od_Scale(1.0 / length, slip), -cut * length, 0.0);
	}
}

static const od_BodyContactDef* od_DefOf(const od_End* a, const od_End* b, const od_BodyContactDef* between)
{
	return a->sim == b->sim ? &a->sim->selfDef : between;
}

static double od_Thickness(od_Sim* const* sims, int count, const od_BodyContactDef* between)
{
	double thickness = between->thickness;
	for (int b = 0; b < count; ++b)
	{
		thickness = sims[b]->selfContact ? fmax(thickness, sims[b]->selfDef.thickness) : thickness;
	}
	return thickness;
}

// Sets pair p's force, friction and normal to those of `from` (the last step's same pair), or to none (NULL).
static void od_TakeForce(od_ContactPair* p, const od_ContactPair* from)
{
	p->force = from ? from->force : 0.0;
	memcpy(p->tangent, from ? from->tangent : (double[3]){ 0, 0, 0 }, sizeof p->tangent);
	memcpy(p->n, from ? from->n : (double[3]){ 0, 0, 1 }, sizeof p->n);
	memcpy(p->anchor, from ? from->anchor : (double[3]){ 0, 0, 0 }, sizeof p->anchor);
	p->anchored = from && from->anchored;
	p->resting = from && from->resting;
}

// The forces of the pairs found again start where the last step's (`previous`) left them (warm start), new
// pairs at zero. The last step's pairs with a force are chained per first particle (head: s->active, which
// od_GatherNear clears), so the match costs the pairs and the forced ones, not a sort. A pair with a force that
// the broad phase no longer finds is kept with it, to fade as a pair beyond reach does (od_MeasurePair): dropped
// at once, a Stiff slab resting on a few pairs lost one pair's force every other step, when the last iterations
// had left that pair 0.9 mm apart, and rocked at 0.16 m/s at 240 steps a second (docs/contact.md, stacks).
static od_Status od_CarryForces(od_PairScratch* s, od_ContactPair* previous, int count, int total)
{
	int* head = s->active;
	for (int p = 0; p < total; ++p)
	{
		head[p] = -1;
	}
	for (int m = 0; m < count; ++m)
	{
		if (previous[m].force > 0.0)
		{
			previous[m].next = head[previous[m].a];
			head[previous[m].a] = m;
		}
	}
	for (int k = 0; k < s->pairCount; ++k)
	{
		od_ContactPair* p = &s->pairs[k];
		int m = head[p->a];
		while (m >= 0 && previous[m].b != p->b)
		{
			m = previous[m].next;
		}
		od_TakeForce(p, m >= 0 ? &previous[m] : NULL);
		if (m >= 0)
		{
			previous[m].force = 0.0; // carried: not kept again below
		}
	}
	od_Status status = OD_OK;
	for (int m = 0; m < count && status == OD_OK; ++m)
	{
		status = previous[m].force > 0.0 ? od_AddPair(s, previous[m].a, previous[m].b) : OD_OK;
		if (previous[m].force > 0.0 && status == OD_OK)
		{
			od_TakeForce(&s->pairs[s->pairCount - 1], &previous[m]);
		}
	}
	return status;
}

// Swaps the pair list into `previous` and finds the pairs of this step anew, their forces carried over where
// they have forces (a group's: count > 1); `between`: the contact between members (od_Candidate's exclusion).
static od_Status od_NewPairs(od_PairScratch* s, od_Sim* const* sims, int count, double thickness,
							 const od_BodyContactDef* between)
{
	od_ContactPair* list = s->previous;
	int capacity = s->previousCapacity;
	s->previous = s->pairs;
	s->previousCapacity = s->pairCapacity;
	s->previousCount = s->pairCount;
	s->pairs = list;
	s->pairCapacity = capacity;
	int total;
	double size = od_Bin(s, sims, count, thickness, &total);
	od_Status status = od_FindPairs(s, sims, total, size, between);
	if (count > 1)
	{
		od_Status carried = od_CarryForces(s, s->previous, status == OD_OK ? s->previousCount : 0, total);
		status = status == OD_OK ? carried : status;
		// The next step's first solve sees every carried force (od_IterateWithForces), then od_GatherNear keeps
		// the near ones. (It saw the first nearCount pairs of this new list, nearCount left by the last step's
		// gather: an arbitrary part of the warm start. A blob dropped on a blob overlapped -0.319 m, -0.104 m
		// with all of it; the upper bar of the stack 0.0027 m/s at 6 s, 0.0014 m/s.)
		s->nearCount = s->pairCount;
	}
	return status;
}

// How far apart (beyond contact, a fraction of the sum of their largest radii) two particles after a step's
// first solve may be and still get forces in its iterations: the rest keep none, and are the projection's
// should they meet.
#define OD_NEAR_SLACK 0.25

// Moves the pairs near after a step's first solve (OD_NEAR_SLACK) to the front of the list (s->nearCount).
// The list is the broad phase's of the last step's end, whose spheres held each particle's path; on two
// stacked 1,000-particle creatures about a tenth of its pairs are near. A pair with a force between members of
// comparable mass or braced (od_Comparable, od_Braced) that its force pushed beyond reach in the first solve
// stays near by distance, so that its force fades (od_MeasurePair) rather than vanishing (with od_CarryForces:
// a Stiff slab on one half as dense rocked at 0.16 m/s at 240 steps a second, at rest now). Between a light
// member and a much heavier one below, a pair's impact force kept so pushed a light Jelly slab
// (on one 1,000 times as dense, 240 steps a second) 0.68 m aside.
static void od_GatherNear(od_PairScratch* s, od_Sim* const* sims, int count, const od_BodyContactDef* between)
{
	od_CacheMoments(s, sims, count);
	int near = 0;
	for (int k = 0; k < s->pairCount; ++k)
	{
		od_ContactPair* pair = &s->pairs[k];
		od_End a = od_EndOf(s, sims, pair->a), b = od_EndOf(s, sims, pair->b);
		od_PairState p = od_Measure(s, pair, &a, &b, between);
		double slack = OD_NEAR_SLACK * (od_ParticleReach(a.sim, a.i) + od_ParticleReach(b.sim, b.i));
		bool close = !p.passed && p.depth > -slack;
		bool held = pair->force > 0.0 && (od_Comparable(s, pair) || od_Braced(s, pair)) &&
					od_Length(od_Sub(b.x1, a.x1)) < od_Reaches(&a, &b) + between->thickness + slack;
		if ((count == 1 || a.sim != b.sim) && (close || held))
		{
			if (close && od_SkinPair_Used(a.sim, b.sim))
			{
				od_V3Store(pair->n, p.c); // the iterations' search starts from it (od_SkinNormal)
			}
			od_ContactPair swap = s->pairs[near];
			s->pairs[near++] = *pair;
			*pair = swap;
		}
		else
		{
			pair->force = 0.0;
		}
	}
	s->nearCount = near;
	memset(s->active, 0, sizeof(int) * (size_t)s->capacity);
}

// Whether a group member's floor holds it inside the iterations (od_FloorReaction): not where goals carry the
// rest (the floor then lifts only what is below the animation, floor.c).
static bool od_FloorInside(const od_Sim* sim)
{
	return sim->hasFloor && !od_Goals_CarryRest(sim);
}

// How much particle i (global g) bears on its floor (od_FloorReaction): 1 where its ellipsoid (the cached
// moment) touches it, more below it, falling to 0 a quarter of its largest radius above it.
static double od_FloorWeight(const od_PairScratch* s, const od_Sim* sim, int i, int g)
{
	double slack = OD_NEAR_SLACK * od_ParticleReach(sim, i);
	return fmax(1.0 + (sqrt(s->moment[9 * g + 8]) - (sim->state.x[3 * i + 2] - sim->floorHeight)) / slack, 0.0);
}

// The floor's reaction to the pairs inside the iterations. The floor acts after them (floor.c), so in the
// solves a member resting on it was free: a heavier member on it pushed it down through the floor, the floor
// lifted it back after the iterations, into the heavy one, deeper every step (a Rubber slab 100 times as dense
// as the slab below sank to 0.040 m above it, the slabs 0.2 m thick: in the solves it moves 2.7 mm a step at
// 1/60 s for each unit of the density ratio, the floor's projection sees none of it). So a member on its
// floor whose pairs' forces (with members of comparable mass, od_Comparable) add up to a push down gets that
// push back, spread over its particles by how much
// each bears on the floor (od_FloorWeight; s->held > 0: some bear, its ellipsoids meeting the floor): held as the
// floor holds it after the iterations, it is pressed between the load and the floor, not moved; its own weight stays
// the floor's projection, and sideways the pairs' forces act as before. Spread evenly over the particles within
// reach of the floor instead, a stiff slab resting on a few of them was strained where nothing touched, and a
// Stiff slab under one 10 times as dense shook at 0.14 m/s (0.007 now). Not on a member that meets its floor with
// its skin (see the top of the file).
static void od_FloorReaction(od_PairScratch* s, od_Sim* const* sims, int count)
{
	memset(s->load, 0, sizeof(double) * (size_t)count);
	for (int k = 0; k < s->nearCount; ++k)
	{
		const od_ContactPair* pair = &s->pairs[k];
		if (pair->force > 0.0 && od_Comparable(s, pair))
		{
			double fz = pair->tangent[2] + pair->force * pair->n[2];
			s->load[s->body[pair->a]] -= fz;
			s->load[s->body[pair->b]] += fz;
		}
	}
	for (int b = 0, first = 0; b < count; first += sims[b++]->graph->n)
	{
		od_Sim* sim = sims[b];
		double push = s->load[b], bearing = s->bearing[b];
		for (int i = 0; push < 0.0 && s->held[b] > 0 && i < sim->graph->n; ++i)
		{
			sim->contactForce[3 * i + 2] -= push * od_FloorWeight(s, sim, i, first + i) / bearing;
		}
	}
}

// Whether sim meets its floor with its skin and the other members with its ellipsoids (od_Sim_SetContactSkin
// without bodies: the add-on's default): its floor does not hold it inside the iterations (see the top of the file).
static bool od_FloorSkinOnly(const od_Sim* sim)
{
	return od_SkinShape_Used(sim) && !sim->skinShape.bodies;
}

// Whether sim meets the other members with its ellipsoids (no skin, or a skin for its floor and colliders only).
static bool od_MembersOnEllipsoids(const od_Sim* sim)
{
	return !od_SkinShape_Used(sim) || !sim->skinShape.bodies;
}

// Whether each member bears on its floor (s->grounded), how much (s->bearing: od_FloorWeight summed over its
// particles) and whether its floor holds it inside the iterations (s->held: it bears and meets its floor with its
// ellipsoids, or the others with its skin too: od_FloorSkinOnly).
static void od_Grounded(od_PairScratch* s, od_Sim* const* sims, int count)
{
	for (int b = 0, first = 0; b < count; first += sims[b++]->graph->n)
	{
		s->bearing[b] = 0.0;
		for (int i = 0; od_FloorInside(sims[b]) && i < sims[b]->graph->n; ++i)
		{
			s->bearing[b] += od_FloorWeight(s, sims[b], i, first + i);
		}
		s->grounded[b] = s->bearing[b] > 0.0;
		s->held[b] = s->grounded[b] && !od_FloorSkinOnly(sims[b]);
	}
}

// Counts each pair with a force for the member of its two that `to` names (-1: none) in s->rise (2 per
// member: the vertical parts of the counted pairs' normals towards it, summed, and their count; od_Rests).
static void od_Rise(od_PairScratch* s, int count, int (*to)(const od_PairScratch* s, int a, int b))
{
	memset(s->rise, 0, sizeof(double) * 2 * (size_t)count);
	for (int k = 0; k < s->nearCount; ++k)
	{
		const od_ContactPair* pair = &s->pairs[k];
		int ma = s->body[pair->a], mb = s->body[pair->b], m = pair->force > 0.0 ? to(s, ma, mb) : -1;
		if (m >= 0)
		{
			s->rise[2 * m] += m == mb ? pair->n[2] : -pair->n[2];
			s->rise[2 * m + 1] += 1.0;
		}
	}
}

// The member of a and b that a supported one may hold up (od_Supports), -1 for none.
static int od_SupportedTo(const od_PairScratch* s, int a, int b)
{
	return s->supported[a] > 0 && !(s->supported[b] > 0) ? b : s->supported[b] > 0 && !(s->supported[a] > 0) ? a : -1;
}

// The member of a and b that the other may brace (od_Bears), -1 for none.
static int od_BracedTo(const od_PairScratch* s, int a, int b)
{
	return a == b ? -1 : od_Bears(s, a, b) ? b : od_Bears(s, b, a) ? a : -1;
}

// Which members are supported (s->supported): on their floor (s->grounded), or resting on supported members
// (their pairs' mean normal rising: od_Rise), from the floor up; then which rest on members that may brace
// them (s->rise, od_Braced). Per member, not per pair: decided by each pair's own normal, a slab's edge pairs,
// sideways, pushed the light slab under it out with the heavy one's weight, and a pair whose normal turned
// gave its light end that weight at once (a Stiff slab 1e6 times as dense spreading over a light one threw it
// at 213 m/s).
static void od_Supports(od_PairScratch* s, int count)
{
	bool more = true;
	for (int b = 0; b < count; ++b)
	{
		s->supported[b] = s->grounded[b] && !s->climbing[b];
	}
	for (int level = 0; level < count && more; ++level)
	{
		more = false;
		od_Rise(s, count, od_SupportedTo);
		for (int b = 0; b < count; ++b)
		{
			bool rests = !(s->supported[b] > 0) && !s->climbing[b] && od_Rests(s, b);
			s->supported[b] = s->supported[b] > 0 || rests;
			more = more || rests;
		}
	}
	od_Rise(s, count, od_BracedTo);
}

// Member b's rotation since the step's start, linearised: I⁻¹ Σ m_i r_i × (x_i - x̄_i), r_i particle i's offset
// from the member's centre at the step's start, x̄_i where it was then (s->pose).
static od_Vec3 od_Turn(const od_PairScratch* s, const od_Sim* sim, int b)
{
	od_Vec3 centre = od_V3Load(s->pose + 13 * b), moment = od_V3(0, 0, 0);
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Vec3 x0 = od_V3Load(sim->previous.x + 3 * i), x1 = od_V3Load(sim->state.x + 3 * i);
		moment = od_MulAdd(moment, sim->def.density * sim->graph->volumes[i], od_Cross(od_Sub(x0, centre), od_Sub(x1, x0)));
	}
	od_Mat3 inverse = od_M3Load(s->pose + 13 * b + 3);
	return od_M3MulV(&inverse, moment);
}

// Whether member b, or a member pressing it with a comparable pair, moves up or down at the step's start faster than
// OD_ROLL_LANDING (s->fast): an impact, not a rest (od_Rolls).
static bool od_Landing(const od_PairScratch* s, int b)
{
	bool landing = s->fast[b] > 0;
	for (int k = 0; !landing && k < s->nearCount; ++k)
	{
		const od_ContactPair* pair = &s->pairs[k];
		int ma = s->body[pair->a], mb = s->body[pair->b];
		landing = pair->force > 0.0 && (ma == b || mb == b) && od_Comparable(s, pair) && s->fast[ma == b ? mb : ma] > 0;
	}
	return landing;
}

// Member pair (lower, upper)'s couple this step (od_MemberRolls), added at none if new; NULL when the list cannot
// grow (out of memory: that pair then has none).
static od_MemberCouple* od_CoupleOf(od_PairScratch* s, int lower, int upper)
{
	for (int c = 0; c < s->coupleCount; ++c)
	{
		if (s->couples[c].lower == lower && s->couples[c].upper == upper)
		{
			return &s->couples[c];
		}
	}
	if (s->coupleCount == s->coupleCapacity)
	{
		int capacity = s->coupleCapacity ? 2 * s->coupleCapacity : 8;
		od_MemberCouple* grown = od_Realloc(s->couples, sizeof *grown * (size_t)capacity);
		if (!grown)
		{
			return NULL;
		}
		s->couples = grown;
		s->coupleCapacity = capacity;
	}
	s->couples[s->coupleCount] = (od_MemberCouple){ .lower = lower, .upper = upper };
	return &s->couples[s->coupleCount++];
}

// Rolling resistance between members (see the top of the file): each interface's couple on its upper member (its
// negative on the lower) grows against their relative rotation since the step's start about axes across the
// interface's normal (dual ascent at the rate of the two as rigid bodies, h² (I_l⁻¹ + I_u⁻¹) per newton metre),
// within OD_ROLL_REACH times the interface's normal force times its particles' mean largest radius (between skins
// too, the skin's patch as wide as the ellipsoids'). Not at an impact (od_Landing) nor at steps longer than
// OD_MEMBER_ROLL_STEP (a group's members step alike).
static void od_MemberRolls(od_PairScratch* s, od_Sim* const* sims, double h2)
{
	for (int e = 0; e < s->interfaceCount && od_ShortStep(sims[0]); ++e)
	{
		const od_Interface* ie = &s->interfaces[e];
		int l = ie->lower, u = ie->upper;
		od_MemberCouple* mc = od_Landing(s, l) || od_Landing(s, u) ? NULL : od_CoupleOf(s, l, u);
		double push = 0.0, reach = 0.0;
		for (int k = 0; mc && k < s->nearCount; ++k)
		{
			const od_ContactPair* pair = &s->pairs[k];
			if (pair->interface == e)
			{
				push += pair->force;
				reach += 0.5 * (od_ParticleReach(sims[l], s->local[pair->a]) + od_ParticleReach(sims[u], s->local[pair->b]));
			}
		}
		if (!mc || !(push > 0.0))
		{
			continue;
		}
		od_Mat3 compliance = od_M3Load(s->pose + 13 * l + 3), upper = od_M3Load(s->pose + 13 * u + 3);
		od_M3AddScaled(&compliance, 1.0, &upper);
		od_Mat3 rate = od_SymmetricInverse(&compliance);
		od_Vec3 n = od_V3Load(ie->n), turn = od_Sub(od_Turn(s, sims[u], u), od_Turn(s, sims[l], l));
		od_Vec3 couple = od_MulAdd(od_V3Load(mc->couple), -1.0 / h2, od_M3MulV(&rate, turn));
		couple = od_MulAdd(couple, -od_Dot(couple, n), n);
		double length = od_Length(couple), limit = OD_ROLL_REACH * push * reach / ie->count;
		od_V3Store(mc->couple, length > limit ? od_Scale(limit / length, couple) : couple);
	}
}

// The floor's rolling resistance (see the top of the file): the couple on a member on its floor that its comparable
// pairs push down (s->load < 0) grows against its rotation since the step's start about horizontal axes (dual
// ascent at the rate of the member as a rigid body: h² I⁻¹ per newton metre, across the floor's normal), within
// OD_ROLL_REACH times that push times the mean largest radius of its particles bearing on the floor
// (od_FloorWeight); after the first OD_ROLL_UPDATES solves of a step it is held. Other members have none, nor any in
// a step that starts at an impact (od_Landing).
static void od_Rolls(od_PairScratch* s, od_Sim* const* sims, int count, double h2)
{
	if (s->rollUpdates >= OD_ROLL_UPDATES)
	{
		return;
	}
	s->rollUpdates++;
	od_MemberRolls(s, sims, h2);
	for (int b = 0, first = 0; b < count; first += sims[b++]->graph->n)
	{
		const od_Sim* sim = sims[b];
		od_Vec3 couple = od_V3(0, 0, 0);
		if (s->held[b] > 0 && s->load[b] < 0.0 && !od_Landing(s, b) && !od_FloorSkinOnly(sim))
		{
			double reach = 0.0;
			for (int i = 0; i < sim->graph->n; ++i)
			{
				reach += od_FloorWeight(s, sim, i, first + i) * od_ParticleReach(sim, i);
			}
			od_Mat3 across = od_M3Load(s->pose + 13 * b + 3); // I⁻¹ across the floor's normal (z)
			across.m[2] = across.m[5] = across.m[6] = across.m[7] = 0.0;
			across.m[8] = 1.0;
			od_Mat3 rate = od_SymmetricInverse(&across);
			od_Vec3 turn = od_Turn(s, sim, b);
			turn.z = 0.0;
			couple = od_MulAdd(od_V3Load(s->roll + 3 * b), -1.0 / h2, od_M3MulV(&rate, turn));
			couple.z = 0.0;
			double length = od_Length(couple), limit = -OD_ROLL_REACH * reach / s->bearing[b] * s->load[b];
			couple = length > limit ? od_Scale(limit / length, couple) : couple;
		}
		od_V3Store(s->roll + 3 * b, couple);
	}
}

// A couple τ on member b (od_Rolls, od_MemberRolls) on its particles' right sides, as the forces m_i (I⁻¹ τ) × r_i
// (r_i from its centre at the step's start), which turn it rigidly and add up to no force.
static void od_ApplyCouple(const od_PairScratch* s, od_Sim* sim, int b, od_Vec3 couple)
{
	od_Mat3 inverse = od_M3Load(s->pose + 13 * b + 3);
	od_Vec3 spin = od_M3MulV(&inverse, couple), centre = od_V3Load(s->pose + 13 * b);
	for (int i = 0; od_Length(spin) > 0.0 && i < sim->graph->n; ++i)
	{
		od_Vec3 arm = od_Sub(od_V3Load(sim->previous.x + 3 * i), centre);
		double* f = sim->contactForce + 3 * i;
		od_V3Store(f, od_MulAdd(od_V3Load(f), sim->def.density * sim->graph->volumes[i], od_Cross(spin, arm)));
	}
}

// The floor's rolling couples (od_Rolls) and those between members (od_MemberRolls) on the particles' right sides.
static void od_ApplyRolls(const od_PairScratch* s, od_Sim* const* sims, int count)
{
	for (int b = 0; b < count; ++b)
	{
		od_ApplyCouple(s, sims[b], b, od_V3Load(s->roll + 3 * b));
	}
	for (int c = 0; c < s->coupleCount; ++c)
	{
		const od_MemberCouple* mc = &s->couples[c];
		od_ApplyCouple(s, sims[mc->upper], mc->upper, od_V3Load(mc->couple));
		od_ApplyCouple(s, sims[mc->lower], mc->lower, od_Scale(-1.0, od_V3Load(mc->couple)));
	}
}

// Writes the pairs' forces onto their particles' right sides (each sim's contactForce; not on an end braced
// immovable, od_Brace), with the floor's reaction to them (od_FloorReaction).
static void od_ApplyForces(od_PairScratch* s, od_Sim* const* sims, int count)
{
	od_Grounded(s, sims, count);
	od_Supports(s, count);
	for (int b = 0; b < count; ++b)
	{
		memset(sims[b]->contactForce, 0, sizeof(double) * 3 * (size_t)sims[b]->graph->n);
	}
	for (int k = 0; k < s->nearCount; ++k)
	{
		const od_ContactPair* pair = &s->pairs[k];
		if (!(pair->force > 0.0))
		{
			continue; // its friction is bounded by μ times this: none
		}
		od_Vec3 n = od_V3Load(pair->n), f = od_MulAdd(od_V3Load(pair->tangent), pair->force, n);
		char braced = od_Braced(s, pair);
		double* fa = sims[s->body[pair->a]]->contactForce + 3 * s->local[pair->a];
		double* fb = sims[s->body[pair->b]]->contactForce + 3 * s->local[pair->b];
		od_V3Store(fa, braced == 'a' ? od_V3Load(fa) : od_Sub(od_V3Load(fa), f));
		od_V3Store(fb, braced == 'b' ? od_V3Load(fb) : od_Add(od_V3Load(fb), f));
	}
	od_ApplyRolls(s, sims, count);
	od_FloorReaction(s, sims, count);
}

// A pair's friction's measure: its displacement in this step and `pull` of how far b had moved from a before it
// since the pair began to stick (its anchor, taken at the step's start where it has none: new, or slid), both in
// a's frame (the anchor turned with a's particle at every step's end, od_BodyContact_TurnAnchors).
static od_Vec3 od_Slip(od_ContactPair* pair, const od_End* a, const od_End* b, double pull)
{
	od_Vec3 d0 = od_Sub(b->x0, a->x0);
	if (!pair->anchored)
	{
		od_V3Store(pair->anchor, d0);
		pair->anchored = true;
	}
	od_Mat3 turned = od_Turning(pair, a, b);
	return od_MulAdd(od_Displacement(pair, a, b), pull, od_M3MulV(&turned, od_Sub(d0, od_V3Load(pair->anchor))));
}

// One update of a pair's forces towards its constraints (dual ascent): the normal force grows while the pair
// is deeper than allowed and shrinks (to 0) while it is apart; the friction force grows against the pair's
// relative tangential displacement over the step, within μ times the normal force (at `slide`, od_PerchedRates).
// The rate is the pair's stiffness as two free particles, shared among the pairs pressing each (so that several
// pairs on one particle do not overshoot it); a particle bound to its body moves less, so this under-relaxes.
static void od_UpdatePair(od_ContactPair* pair, const od_End* a, const od_End* b, double mu, double rate,
						  double slide, const od_Interface* e, double pull)
{
	if (!pair->touching)
	{
		pair->force = 0.0;
		memset(pair->tangent, 0, sizeof pair->tangent);
		pair->anchored = false;
		return;
	}
	double share = e && e->load > 0.0 ? pair->force * e->count / e->load : 1.0;
	pair->force = e ? fmax(pair->force + e->change - rate * (pair->gap - e->gap), 0.0)
					: fmax(pair->force - rate * pair->gap, 0.0);
	od_Vec3 n = od_V3Load(pair->n), rel = od_Slip(pair, a, b, pull);
	od_Vec3 t = e ? od_MulAdd(od_MulAdd(od_V3Load(pair->tangent), share, od_V3Load(e->shift)), -rate,
							  od_Sub(rel, od_V3Load(e->slip)))
				  : od_MulAdd(od_V3Load(pair->tangent), -slide, rel);
	t = od_MulAdd(t, -od_Dot(t, n), n);
	double length = od_Length(t), limit = mu * pair->force;
	od_V3Store(pair->tangent, length > limit ? od_Scale(limit / length, t) : t);
	pair->anchored = length <= limit;
}

// Measures a near pair at the current centres (gap, touching, its normal) and counts it on its
// particles (s->pressing) when it presses them.
static void od_MeasurePair(od_PairScratch* s, od_ContactPair* pair, const od_End* a, const od_End* b,
						   const od_BodyContactDef* d)
{
	od_Vec3 d1 = od_Sub(b->x1, a->x1);
	double near = od_Reaches(a, b) + d->thickness;
	if (od_Dot(d1, d1) >= near * near)
	{
		// Far now: a force it carries fades by the rate times how far it is beyond reach (it was dropped at
		// once: a pair of a resting stack of slabs pushed that far by its warm force in a step's first solve lost
		// a sixth of the upper slab's weight, and the stack bounced); a pair that crossed within the step is the
		// projection's.
		pair->touching = pair->force > 0.0;
		pair->gap = sqrt(od_Dot(d1, d1)) - near;
		return;
	}
	od_PairState p = od_Measure(s, pair, a, b, d);
	pair->touching = !p.passed;
	pair->gap = p.allowed - p.depth;
	if (pair->touching && (pair->gap < 0.0 || pair->force > 0.0))
	{
		s->pressing[pair->a]++;
		s->pressing[pair->b]++;
		// Re-aimed at every update: round bodies' pairs turn within a step (a blob on a blob: skinned
		// overlap -0.026 m with the normal set once a step, -0.018 m re-aimed; the bars alike).
		od_V3Store(pair->n, p.along ? p.c : od_PushDirection(s, pair, p.c));
	}
}

// How far particle i moves per newton pushed at it with its member held: the inverse of its row's diagonal
// in the global matrix (inertia m/h² and its edges' k w_ij (u_i + u_j)).
static double od_OwnCompliance(const od_Sim* sim, int i)
{
	const od_Graph* graph = sim->graph;
	const double* u = od_ElasticVolumes(sim);
	double diagonal = sim->def.density * graph->volumes[i] / (sim->def.dt * sim->def.dt);
	for (int k = graph->adjStart[i]; k < graph->adjStart[i + 1]; ++k)
	{
		diagonal += sim->def.stiffness * od_EdgeVolume(sim, u, i, k);
	}
	return 1.0 / diagonal;
}

// The interface of members lower and upper, added if new; -1 when the list cannot grow (out of memory: its
// contacts then take their own updates only).
static int od_InterfaceOf(od_PairScratch* s, int lower, int upper)
{
	for (int e = 0; e < s->interfaceCount; ++e)
	{
		if (s->interfaces[e].lower == lower && s->interfaces[e].upper == upper)
		{
			return e;
		}
	}
	if (s->interfaceCount == s->interfaceCapacity)
	{
		int capacity = s->interfaceCapacity ? 2 * s->interfaceCapacity : 8;
		od_Interface* grown = od_Realloc(s->interfaces, sizeof *grown * (size_t)capacity);
		s->interfaces = grown ? grown : s->interfaces;
		size_t size = sizeof(double) * 2 * (size_t)capacity * (size_t)(2 * capacity + 1); // od_CoarseFriction's
		double* system = grown ? od_Realloc(s->system, size) : NULL;
		s->system = system ? system : s->system;
		if (!system)
		{
			return -1;
		}
		s->interfaceCapacity = capacity;
	}
	s->interfaces[s->interfaceCount] = (od_Interface){ .lower = lower, .upper = upper };
	return s->interfaceCount++;
}

// Whether a near pair is in contact: its force acts, or would.
static bool od_InContact(const od_ContactPair* pair)
{
	return pair->touching && (pair->gap < 0.0 || pair->force > 0.0);
}

// A pair's gap as its interface's mean gap counts it (od_Coarse): a skin pair's (od_SkinPair_Used) none beyond
// contact. Its normal, the separating axis re-aimed at every update, can turn and find it a few mm apart at once,
// which the members' rigid step read as the whole interface lifting: two Rubber spheres at rest on each other, one
// of the upper's four pairs found 1.6 mm apart, took 70 % of its weight off the interface for an update and put 145 %
// back at the next; kicked so from rest, the two tipped over (docs/contact.md, "Stacks", stop 37, skinstack). The
// pair's own update lets its force go (od_UpdatePair).
static double od_CoarseGap(od_Sim* const* sims, const od_PairScratch* s, const od_ContactPair* pair)
{
	return od_SkinPair_Used(sims[s->body[pair->a]], sims[s->body[pair->b]]) ? fmin(pair->gap, 0.0) : pair->gap;
}

// The interfaces of this update: the near pairs in contact grouped by their members (each pair's index in its
// `interface`, -1: none; pairs of comparable members only, od_Comparable).
static void od_Interfaces(od_PairScratch* s, od_Sim* const* sims)
{
	s->interfaceCount = 0;
	bool friction = od_FrictionStep(sims); // what od_CoarseFriction reads, gathered only where it acts
	for (int k = 0; k < s->nearCount; ++k)
	{
		od_ContactPair* pair = &s->pairs[k];
		int e = od_InContact(pair) && od_Comparable(s, pair) ? od_InterfaceOf(s, s->body[pair->a], s->body[pair->b])
																: -1;
		pair->interface = e;
		if (e >= 0)
		{
			od_Interface* ie = &s->interfaces[e];
			ie->count++;
			od_V3Store(ie->n, od_Add(od_V3Load(ie->n), od_V3Load(pair->n)));
			ie->gap += od_CoarseGap(sims, s, pair);
			ie->local += od_OwnCompliance(sims[s->body[pair->a]], s->local[pair->a]) +
						 od_OwnCompliance(sims[s->body[pair->b]], s->local[pair->b]);
			if (friction)
			{
				od_End a = od_EndOf(s, sims, pair->a), b = od_EndOf(s, sims, pair->b);
				od_Vec3 n = od_V3Load(pair->n), rel = od_Displacement(pair, &a, &b);
				od_V3Store(ie->slip, od_Add(od_V3Load(ie->slip), od_MulAdd(rel, -od_Dot(rel, n), n)));
				od_V3Store(ie->point, od_Add(od_V3Load(ie->point), od_Scale(0.5, od_Add(a.x1, b.x1))));
				ie->load += pair->force;
			}
		}
	}
}

// How far member m moves along u per newton along v of a push on it: h²/M (u·v), its vertical part left out
// where the floor's reaction holds it (od_FloorReaction), which cancels the pushes down.
static double od_RigidCompliance(const od_PairScratch* s, int m, od_Vec3 u, od_Vec3 v, double h2)
{
	double along = od_Dot(u, v) - (s->held[m] > 0 ? u.z * v.z : 0.0);
	return h2 * along / s->mass[m];
}

// +1 where member m is interface f's upper member (its forces push m along f's normal), -1 its lower, else 0.
static double od_Side(const od_Interface* f, int m)
{
	return m == f->upper ? 1.0 : m == f->lower ? -1.0 : 0.0;
}

// Solves the symmetric positive definite n × n system a x = x in place (Cholesky, row-major); false when it is
// not positive definite.
static bool od_SolveDense(double* a, double* x, int n)
{
	for (int j = 0; j < n; ++j)
	{
		double d = a[j * n + j];
		for (int k = 0; k < j; ++k)
		{
			d -= a[j * n + k] * a[j * n + k];
		}
		if (!(d > 0.0))
		{
			return false;
		}
		a[j * n + j] = sqrt(d);
		for (int i = j + 1; i < n; ++i)
		{
			double v = a[i * n + j];
			for (int k = 0; k < j; ++k)
			{
				v -= a[i * n + k] * a[j * n + k];
			}
			a[i * n + j] = v / a[j * n + j];
		}
	}
	for (int i = 0; i < n; ++i)
	{
		for (int k = 0; k < i; ++k)
		{
			x[i] -= a[i * n + k] * x[k];
		}
		x[i] /= a[i * n + i];
	}
	for (int i = n - 1; i >= 0; --i)
	{
		for (int k = i + 1; k < n; ++k)
		{
			x[i] -= a[k * n + i] * x[k];
		}
		x[i] /= a[i * n + i];
	}
	return true;
}

// The members' rigid motions (see the top of the file): one Newton step of every interface's mean gap with the
// members as rigid bodies (a member on its floor held vertically), each contact's particles adding their own
// compliance, spread evenly over the interface's contacts (e->change); each contact's own update then acts on
// its gap less the mean (od_UpdatePair).
static void od_Coarse(od_PairScratch* s, double h2)
{
	int n = s->interfaceCount;
	if (n == 0)
	{
		return; // no interface, and no system allocated
	}
	double *a = s->system, *x = s->system + (size_t)n * (size_t)n;
	for (int e = 0; e < n; ++e)
	{
		od_Interface* ie = &s->interfaces[e];
		double length = od_Length(od_V3Load(ie->n));
		od_V3Store(ie->n, length > 0.0 ? od_Scale(1.0 / length, od_V3Load(ie->n)) : od_V3(0, 0, 1));
		ie->gap /= ie->count;
		ie->local /= ie->count;
		x[e] = -ie->gap;
	}
	for (int e = 0; e < n; ++e)
	{
		const od_Interface* ie = &s->interfaces[e];
		for (int f = 0; f < n; ++f)
		{
			const od_Interface* jf = &s->interfaces[f];
			od_Vec3 ne = od_V3Load(ie->n), nf = od_V3Load(jf->n);
			a[e * n + f] = od_Side(jf, ie->upper) * od_RigidCompliance(s, ie->upper, ne, nf, h2) -
						   od_Side(jf, ie->lower) * od_RigidCompliance(s, ie->lower, ne, nf, h2) +
						   (e == f ? ie->local / ie->count : 0.0);
		}
	}
	bool solved = od_SolveDense(a, x, n);
	for (int e = 0; e < n; ++e)
	{
		s->interfaces[e].change = solved ? x[e] / s->interfaces[e].count : 0.0;
	}
}

// Two unit directions across unit n, each across the other.
static void od_Across(od_Vec3 n, od_Vec3* t)
{
	t[0] = od_Unit(od_Cross(n, fabs(n.x) < 0.9 ? od_V3(1, 0, 0) : od_V3(0, 1, 0)));
	t[1] = od_Cross(n, t[0]);
}

// How far member m moves interface e's point along u per newton along v at interface f's point, as a rigid body
// that also turns: od_RigidCompliance's plus h² (r_e × u)ᵀ I⁻¹ (r_f × v), r from its centre at the step's start.
static double od_TurningCompliance(const od_PairScratch* s, int m, const od_Interface* e, od_Vec3 u,
								   const od_Interface* f, od_Vec3 v, double h2)
{
	od_Vec3 centre = od_V3Load(s->pose + 13 * m);
	od_Mat3 inverse = od_M3Load(s->pose + 13 * m + 3);
	od_Vec3 ru = od_Cross(od_Sub(od_V3Load(e->point), centre), u);
	od_Vec3 rv = od_Cross(od_Sub(od_V3Load(f->point), centre), v);
	return od_RigidCompliance(s, m, u, v, h2) + h2 * od_Dot(ru, od_M3MulV(&inverse, rv));
}

// The members' rigid motions for friction, after od_Coarse (its normals): one Newton step of every interface's mean
// slip across its normal, the members rigid bodies that turn, each contact's particles adding their own compliance,
// spread over its contacts by their normal forces (e->shift, od_UpdatePair; spread evenly and at 1/60 s too, a Stiff
// slab 10 times as dense as the one below crept off its lighter pairs' Coulomb bounds, 0.102 m/s at 13 s); each
// contact's own update then acts on its slip less the mean. A contact's own rate moves a stiff member by the share of
// its particles that touch: a Stiff slab on one half as dense at 1/24 s, resting on 5 of its 100 particles, crept aside
// at 0.007 m/s, the pairs' turned normals leaning more as it went (150-220 N aside of its 2,750 N weight), its friction
// lagging them by a few newtons, and slid off at 6 s (docs/contact.md, "Stacks", eleventh round). Not between skins
// (od_SkinPair_Used: no bumps to lean on; the bars of tests/test_skin_pairs.py rested 7.6 mm apart with it, 6.1
// without), nor at steps of OD_FRICTION_STEP or shorter (a group's members step alike).
static void od_CoarseFriction(od_PairScratch* s, od_Sim* const* sims, double h2)
{
	int n = 2 * s->interfaceCount;
	if (n == 0 || !od_FrictionStep(sims))
	{
		return; // no interface (and no system allocated), or shifts and slips left at none (od_InterfaceOf)
	}
	double *a = s->system, *x = s->system + (size_t)n * (size_t)n;
	od_Vec3 across[2];
	for (int e = 0; e < s->interfaceCount; ++e)
	{
		od_Interface* ie = &s->interfaces[e];
		od_V3Store(ie->slip, od_Scale(1.0 / ie->count, od_V3Load(ie->slip)));
		od_V3Store(ie->point, od_Scale(1.0 / ie->count, od_V3Load(ie->point)));
		od_Across(od_V3Load(ie->n), across);
		x[2 * e] = -od_Dot(od_V3Load(ie->slip), across[0]);
		x[2 * e + 1] = -od_Dot(od_V3Load(ie->slip), across[1]);
	}
	for (int r = 0; r < n; ++r)
	{
		const od_Interface* ie = &s->interfaces[r / 2];
		od_Across(od_V3Load(ie->n), across);
		od_Vec3 u = across[r % 2];
		for (int c = 0; c < n; ++c)
		{
			const od_Interface* jf = &s->interfaces[c / 2];
			od_Across(od_V3Load(jf->n), across);
			od_Vec3 v = across[c % 2];
			a[r * n + c] = od_Side(jf, ie->upper) * od_TurningCompliance(s, ie->upper, ie, u, jf, v, h2) -
						   od_Side(jf, ie->lower) * od_TurningCompliance(s, ie->lower, ie, u, jf, v, h2) +
						   (r == c ? ie->local / ie->count : 0.0);
		}
	}
	bool solved = od_SolveDense(a, x, n);
	for (int e = 0; e < s->interfaceCount; ++e)
	{
		od_Interface* ie = &s->interfaces[e];
		od_Across(od_V3Load(ie->n), across);
		od_Vec3 shift = od_MulAdd(od_Scale(x[2 * e], across[0]), x[2 * e + 1], across[1]);
		bool used = solved && !od_SkinPair_Used(sims[ie->lower], sims[ie->upper]);
		od_V3Store(ie->shift, used ? od_Scale(1.0 / ie->count, shift) : od_V3(0, 0, 0));
		od_V3Store(ie->slip, used ? od_V3Load(ie->slip) : od_V3(0, 0, 0));
	}
}

// How many pairs in contact each member rests on that lead to much heavier members (s->perched, od_Perched).
static void od_CountPerched(od_PairScratch* s, int count)
{
	memset(s->perched, 0, sizeof(int) * (size_t)count);
	for (int k = 0; k < s->nearCount; ++k)
	{
		int m = od_InContact(&s->pairs[k]) ? od_Perched(s, &s->pairs[k]) : -1;
		if (m >= 0)
		{
			s->perched[m]++;
		}
	}
}

// How far member m's point at r from its centre (at the step's start) moves along unit u per newton along u, as a
// rigid body that also turns: h² (1 / M + (r × u)ᵀ I⁻¹ (r × u)).
static double od_PointCompliance(const od_PairScratch* s, int m, od_Vec3 r, od_Vec3 u, double h2)
{
	od_Mat3 inverse = od_M3Load(s->pose + 13 * m + 3);
	od_Vec3 ru = od_Cross(r, u);
	return h2 * (1.0 / s->mass[m] + od_Dot(ru, od_M3MulV(&inverse, ru)));
}

// The rates of a pair's normal force and friction (od_UpdatePair): `rate`, its particles' own, but for a member m
// resting on much heavier ones (the pair's od_Perched; -1: none) those of the member as a rigid body at the pair's
// particle (along the normal; across it, the larger of two directions' compliances), its count pairs sharing it, plus
// the particle's own compliance (od_OwnCompliance): 1 / (count c_rigid + c_own), where larger. Such a member takes no
// rigid step (od_Coarse, od_CoarseFriction: comparable members only), and a particle's own rate moves it by the share
// of its particles that touch: a Rubber slab on one 1,000 times as dense (crushed bumpy under its own weight) at 24
// steps a second rested on 3-5 pairs, two of three at their Coulomb bound, and rocked at 0.17 m/s, or slid off one
// settled first (0.95 m aside at 7 s); with these rates it rests from 1 s (docs/contact.md, "Stacks", stop 46). The
// heavier end hardly moves: the light member's inertia is what counts. At 3 or 10 times the rates the slab slid off.
//
// Only for a member resting on OD_PERCHED_PAIRS pairs or more: on fewer it is balanced on them and turns about
// them, and at the rigid rate a Rubber sphere on one 100 times as dense at 60 steps a second rolled off (0.70 m aside
// at 6 s in 3 of 4 drops; 0.07-0.09 m with the limit, as before).
static void od_PerchedRates(const od_PairScratch* s, od_Sim* const* sims, const od_ContactPair* pair, int m,
							double rate, double h2, double* normal, double* friction)
{
	*normal = *friction = rate;
	if (m < 0 || s->perched[m] < OD_PERCHED_PAIRS)
	{
		return;
	}
	int p = s->body[pair->a] == m ? pair->a : pair->b, i = s->local[p];
	od_Vec3 r = od_Sub(od_V3Load(sims[m]->state.x + 3 * i), od_V3Load(s->pose + 13 * m)), n = od_V3Load(pair->n), t[2];
	od_Across(n, t);
	double own = od_OwnCompliance(sims[m], i), count = s->perched[m];
	double across = fmax(od_PointCompliance(s, m, r, t[0], h2), od_PointCompliance(s, m, r, t[1], h2));
	*normal = fmax(rate, 1.0 / (count * od_PointCompliance(s, m, r, n, h2) + own));
	*friction = fmax(rate, 1.0 / (count * across + own));
}

// A pair whose lighter member `light` rests on a much heavier one (od_Perched; -1: none) measures its friction's slip
// against where the heavier end stood at the step's start. The heavier member's floor holds it after the iterations, so
// in the solves it falls (a Jelly slab 1,000 times as dense as the one on it: its top particles 20 mm a step at 1/24 s,
// under 0.3 mm once the floor has put them back), and across pair normals leaning 10-25 degrees on its crushed, bumpy
// top that fall read as the pairs' slip: 2-5 mm a step, in as many directions as the normals lean. The light slab's
// friction, at its Coulomb bound, held against those (load-weighted cosine to the step's true slip -0.05 to -0.7), 0.1
// of its weight of the 0.55 its bounds allowed against the normals' lean, and the slab slid off (0.88 m aside at 3 s;
// docs/contact.md, "Stop 48"). The normal force keeps the heavier end where it is: measured against its start too, at
// 24 steps a second Rubber and Stiff slabs on ones 10 times as dense shook (0.47, 0.10 m/s) and a Stiff slab on one
// 1,000 times as dense (0.12 m/s).
static void od_StillBelow(const od_PairScratch* s, const od_ContactPair* pair, int light, od_End* a, od_End* b)
{
	od_End* heavy = light < 0 ? NULL : s->body[pair->a] == light ? b : a;
	if (heavy)
	{
		heavy->x1 = heavy->x0;
	}
}

// After each solve of a step's iterations: measures the near pairs, updates their forces and puts them on
// the particles' right sides for the next solve. The pairs pressing a particle are those counted at the
// last update (s->active; none at the first), so that one pass does it.
static void od_UpdateForces(od_PairScratch* s, od_Sim* const* sims, int count, const od_BodyContactDef* between)
{
	od_CacheMoments(s, sims, count);
	memset(s->pressing, 0, sizeof(int) * (size_t)od_GroupParticles(sims, count));
	double h2 = sims[0]->def.dt * sims[0]->def.dt;
	for (int k = 0; k < s->nearCount; ++k)
	{
		od_ContactPair* pair = &s->pairs[k];
		od_End a = od_EndOf(s, sims, pair->a), b = od_EndOf(s, sims, pair->b);
		od_Brace(s, pair, &a, &b);
		od_MeasurePair(s, pair, &a, &b, between);
	}
	od_Interfaces(s, sims);
	od_Coarse(s, h2);
	od_CoarseFriction(s, sims, h2);
	od_CountPerched(s, count);
	double pull = od_FrictionStep(sims) ? 0.0 : OD_ANCHOR_PULL;
	for (int k = 0; k < s->nearCount; ++k)
	{
		od_ContactPair* pair = &s->pairs[k];
		od_End a = od_EndOf(s, sims, pair->a), b = od_EndOf(s, sims, pair->b);
		od_Brace(s, pair, &a, &b);
		int ca = s->active[pair->a] > 1 ? s->active[pair->a] : 1, cb = s->active[pair->b] > 1 ? s->active[pair->b] : 1;
		double rate, slide;
		int light = od_Perched(s, pair);
		od_PerchedRates(s, sims, pair, light, OD_FORCE_RATE / (h2 * (ca / a.mass + cb / b.mass)), h2, &rate, &slide);
		od_StillBelow(s, pair, light, &a, &b);
		od_UpdatePair(pair, &a, &b, between->friction, rate, slide,
					  pair->interface >= 0 ? &s->interfaces[pair->interface] : NULL, pull);
	}
	od_Rolls(s, sims, count, h2);
	int* swap = s->active;
	s->active = s->pressing;
	s->pressing = swap;
	od_ApplyForces(s, sims, count);
}

// After the iterations, with the pairs the broad phase found at the step's end: those still in contact are
// pushed apart (Gauss-Seidel passes) with friction on the push, as before the forces existed; at rest the
// forces hold the pairs and this pushes (nearly) nothing.
static od_Status od_ProjectPairs(od_PairScratch* s, od_Sim* const* sims, int count, const od_BodyContactDef* between)
{
	od_Status status = OD_OK;
	int tick = 0;
	if (s->pairCount > 0) // a body alone with self-contact and nothing near pays nothing
	{
		od_CacheMoments(s, sims, count);
		memset(s->moved, 0, sizeof(int) * (size_t)od_GroupParticles(sims, count));
	}
	for (int pass = 0; pass <= OD_PAIR_PASSES && status == OD_OK; ++pass)
	{
		for (int k = 0; k < s->pairCount; ++k)
		{
			od_ContactPair* pair = &s->pairs[k];
			pair->clear = pass == 0 ? 0 : pair->clear;
			if (pass < OD_PAIR_PASSES && pair->clear > s->moved[pair->a] && pair->clear > s->moved[pair->b])
			{
				continue; // measured clear, and nothing of it moved since: the same measure again
			}
			od_End a = od_EndOf(s, sims, pair->a), b = od_EndOf(s, sims, pair->b);
			const od_BodyContactDef* d = od_DefOf(&a, &b, between);
			pair->push = pass == 0 ? 0.0 : pair->push;
			if (pass < OD_PAIR_PASSES)
			{
				++tick;
				bool pushed = od_ResolvePair(s, pair, &a, &b, d);
				pair->clear = pushed ? 0 : tick;
				s->moved[pair->a] = pushed ? tick : s->moved[pair->a];
				s->moved[pair->b] = pushed ? tick : s->moved[pair->b];
			}
			else if (pair->push > 0.0 && d->friction > 0.0)
			{
				od_PairFriction(s, pair, &a, &b, d->friction);
			}
		}
	}
	return status;
}

// Whether sim may roll on a patch after the projections (surface_contact.c): a member meeting its floor with its
// skin alone at steps of OD_MEMBER_ROLL_STEP or shorter; one meeting everything with its ellipsoids at longer
// steps (see the top of the file).
static bool od_PatchRolling(const od_Sim* sim)
{
	return od_FloorSkinOnly(sim) ? od_ShortStep(sim) : !od_SkinShape_Used(sim) && !od_ShortStep(sim);
}

// Whether member b rolls on its floor's or colliders' patch after the projections (surface_contact.c): a member
// that may (od_PatchRolling), pressed down by comparable ones, not at an impact.
static bool od_FloorRolls(const od_PairScratch* s, od_Sim* const* sims, int b)
{
	return od_PatchRolling(sims[b]) && sims[b]->surface.force &&
		   (s->grounded[b] || sims[b]->colliders.count) &&
		   s->load[b] < 0.0 && !od_Landing(s, b);
}

// Particle p's pair force f along n (towards its member) onto its member's patch when that member rests on a
// floor-rolling one (n up, OD_HELD_RISE).
static void od_OnPatch(const od_PairScratch* s, od_Sim* const* sims, int p, int under, double f, od_Vec3 n)
{
	od_Sim* sim = sims[s->body[p]];
	if (sims[under]->surface.rolls == OD_ROLL_FLOOR && n.z > OD_HELD_RISE && sim->surface.rolls != OD_ROLL_FLOOR &&
		od_PatchRolling(sim) && sim->surface.force && !od_Landing(s, s->body[p]))
	{
		int i = s->local[p];
		sim->surface.push[i] += f;
		od_V3Store(sim->surface.normal + 3 * i, od_MulAdd(od_V3Load(sim->surface.normal + 3 * i), f, n));
		sim->surface.rolls = OD_ROLL_MEMBER;
	}
}

// The patches that roll the members back after the projections (surface_contact.c): a floor-rolling member's is
// its floor's lift; one resting on it, its comparable pairs' forces from below.
static void od_PatchRolls(od_PairScratch* s, od_Sim* const* sims, int count, const od_BodyContactDef* between)
{
	for (int b = 0; b < count; ++b)
	{
		if (s->alone[b])
		{
			continue; // its floor acted inside its iterations, as alone
		}
		sims[b]->surface.rolls = od_FloorRolls(s, sims, b) ? OD_ROLL_FLOOR : OD_ROLL_NONE;
		sims[b]->surface.rollFriction = between->friction;
		if (sims[b]->surface.force && sims[b]->surface.rolls == OD_ROLL_NONE)
		{
			memset(sims[b]->surface.push, 0, sizeof(double) * (size_t)sims[b]->graph->n);
			memset(sims[b]->surface.normal, 0, sizeof(double) * 3 * (size_t)sims[b]->graph->n);
		}
	}
	for (int k = 0; k < s->nearCount; ++k)
	{
		const od_ContactPair* pair = &s->pairs[k];
		if (pair->force > 0.0 && od_Comparable(s, pair))
		{
			od_Vec3 n = od_V3Load(pair->n);
			od_OnPatch(s, sims, pair->b, s->body[pair->a], pair->force, n);
			od_OnPatch(s, sims, pair->a, s->body[pair->b], pair->force, od_Scale(-1.0, n));
		}
	}
}

// The iterations of a group's step with the forces of its pairs between them (see the top of the file): the
// pairs are those the broad phase found at the end of the last step, the first solve with their forces, then
// those near after it updated after every solve.
static od_Status od_IterateWithForces(od_PairScratch* s, od_Sim* const* sims, int count, const od_BodyContactDef* between)
{
	od_CacheMoments(s, sims, count); // the first solve's floor reaction (od_FloorWeight)
	od_MemberMasses(s, sims, count);
	memset(s->roll, 0, sizeof(double) * 3 * (size_t)count); // none at a step's start: not part of the group's state
	s->coupleCount = 0;
	s->rollUpdates = 0;
	od_ApplyForces(s, sims, count);
	od_Status status = OD_OK;
	for (int b = 0; b < count && status == OD_OK; ++b)
	{
		bool again = s->alone[b];
		while (again && status == OD_OK)
		{
			status = od_Step_Advance(sims[b], &again);
		}
	}
	bool more = true, first = true;
	while (more && status == OD_OK)
	{
		more = false;
		// Every member takes each round's pair, also one that has met its tolerance, until all have.
		for (int b = 0; b < count && status == OD_OK; ++b)
		{
			if (s->alone[b])
			{
				continue;
			}
			bool again = false;
			status = od_Step_Advance(sims[b], &again);
			od_Iteration* it = &sims[b]->iteration;
			if (first)
			{
				od_Tolerance_PlainPlan(&it->plan);
			}
			more = more || again;
		}
		if (first)
		{
			od_GatherNear(s, sims, count, between);
			s->warmNormals = true;
			first = false;
		}
		if (status == OD_OK)
		{
			od_UpdateForces(s, sims, count, between);
		}
	}
	for (int b = 0; b < count; ++b)
	{
		memset(sims[b]->contactForce, 0, sizeof(double) * 3 * (size_t)sims[b]->graph->n);
	}
	od_PatchRolls(s, sims, count, between);
	s->warmNormals = false;
	return status;
}

// Sizes s->self for a simulation of n particles and `pairs` near pairs (the response is sized by
// od_SelfParticles).
static od_Status od_SelfSolveReserve(od_PairScratch* s, int n, int pairs)
{
	od_SelfSolve* q = s->self ? s->self : od_AllocZero(1, sizeof *q);
	s->self = q;
	if (q && q->n < n)
	{
		od_Free(q->slot);
		od_Free(q->particles);
		od_Free(q->column);
		q->slot = od_Alloc(sizeof(int) * (size_t)n);
		q->particles = od_Alloc(sizeof(int) * (size_t)n);
		q->column = od_Alloc(sizeof(double) * 3 * (size_t)n);
		q->n = q->slot && q->particles && q->column ? n : 0;
		for (int i = 0; i < q->n; ++i)
		{
			q->slot[i] = -1;
		}
	}
	if (q && q->n >= n && q->pairCapacity < pairs)
	{
		od_Free(q->coupling);
		od_Free(q->applied);
		od_Free(q->slip);
		q->coupling = od_Alloc(sizeof(double) * (size_t)pairs * (size_t)pairs);
		q->applied = od_Alloc(sizeof(double) * 3 * (size_t)pairs);
		q->slip = od_Alloc(sizeof(double) * 3 * (size_t)pairs);
		q->pairCapacity = q->coupling && q->applied && q->slip ? pairs : 0;
	}
	if (!q || q->n < n || q->pairCapacity < pairs)
	{
		return od_Fail(OD_ERROR_MEMORY, "out of memory for the self-contact of %d pairs", pairs);
	}
	return OD_OK;
}

// Lists the near pairs' particles (s->self's slots and particles) and sizes the response for them.
static od_Status od_SelfParticles(od_PairScratch* s)
{
	od_SelfSolve* q = s->self;
	for (int k = 0; k < q->count; ++k)
	{
		q->slot[q->particles[k]] = -1;
	}
	q->count = 0;
	for (int k = 0; k < s->nearCount; ++k)
	{
		int ends[2] = { s->local[s->pairs[k].a], s->local[s->pairs[k].b] };
		for (int e = 0; e < 2; ++e)
		{
			if (q->slot[ends[e]] < 0)
			{
				q->slot[ends[e]] = q->count;
				q->particles[q->count++] = ends[e];
			}
		}
	}
	if (q->responseCapacity < q->count)
	{
		od_Free(q->response);
		q->response = od_Alloc(sizeof(double) * (size_t)q->count * (size_t)q->count);
		q->responseCapacity = q->response ? q->count : 0;
	}
	return q->response ? OD_OK : od_Fail(OD_ERROR_MEMORY, "out of memory for the self-contact of %d particles", q->count);
}

// The response of the near pairs' particles to a force on each (A⁻¹ between them): one substitution per
// three particles, a unit force on each along its own axis. The matrix is fixed during a step.
static void od_SelfResponse(od_Sim* sim, od_SelfSolve* q)
{
	int n = sim->graph->n, count = q->count;
	for (int first = 0; first < count; first += 3)
	{
		memset(q->column, 0, sizeof(double) * 3 * (size_t)n);
		for (int c = 0; c < 3 && first + c < count; ++c)
		{
			q->column[3 * q->particles[first + c] + c] = 1.0;
		}
		od_GlobalResponse(sim, q->column);
		for (int c = 0; c < 3 && first + c < count; ++c)
		{
			for (int r = 0; r < count; ++r)
			{
				q->response[r * count + first + c] = q->column[3 * q->particles[r] + c];
			}
		}
	}
}

// How far pair k's ends move apart per newton of a force on pair l (on l's b, its negative on l's a), along
// the force: the response is the same along x, y and z.
static double od_PairResponse(const od_SelfSolve* q, const od_PairScratch* s, const od_ContactPair* k,
							  const od_ContactPair* l)
{
	const double* z = q->response;
	int c = q->count, ak = q->slot[s->local[k->a]], bk = q->slot[s->local[k->b]];
	int al = q->slot[s->local[l->a]], bl = q->slot[s->local[l->b]];
	return z[bk * c + bl] - z[bk * c + al] - z[ak * c + bl] + z[ak * c + al];
}

// A pair's whole force on its b: the normal force along n and the friction force.
static od_Vec3 od_PairForce(const od_ContactPair* pair)
{
	return od_MulAdd(od_V3Load(pair->tangent), pair->force, od_V3Load(pair->n));
}

// A near pair of one body as a half-space for the step's solves: at the first measure its normal is its
// centre line at the step's start, and how deep it may stay is set (a pair that began overlapping leaves at the
// recovery speed); then its gap along that normal at the current centres and ellipsoids. Fixed for the step,
// the constraints are linear and od_SolveForces settles. Turned towards the bodies' surface normals as between
// bodies (od_PushDirection), the rod's ends held pressed never settled (fastest particle 2.2 m/s over the last
// of 10 s, 0.026 m/s not turned, both at 30 sweeps; docs/contact.md): a rod's end particles' outward
// directions lie along it.
static void od_MeasureSelfPair(od_PairScratch* s, od_ContactPair* pair, const od_End* a, const od_End* b,
							   const od_BodyContactDef* d, bool first)
{
	od_Mat3 ma = od_M3Load(s->moment + 9 * pair->a), mb = od_M3Load(s->moment + 9 * pair->b);
	if (first)
	{
		od_Vec3 d0 = od_Sub(b->x0, a->x0);
		double l0 = od_Length(d0);
		od_Vec3 c = l0 > 0.0 ? od_Scale(1.0 / l0, d0) : od_V3(0, 0, 1);
		od_V3Store(pair->n, c);
		double depth = od_Support(&ma, c) + od_Support(&mb, c) + d->thickness - l0;
		pair->allowed = fmax(depth - od_RecoveryLimit(a->sim), 0.0);
	}
	od_Vec3 n = od_V3Load(pair->n);
	pair->gap = od_Dot(n, od_Sub(b->x1, a->x1)) - (od_Support(&ma, n) + od_Support(&mb, n) + d->thickness) + pair->allowed;
	pair->touching = true;
}

// Gauss-Seidel sweeps over a body's near pairs after each solve (od_SolveForces). 10 and 30 gave the same
// tails within 0.1 mm and the rod's ends at rest (0.015 / 0.026 m/s), at 0.25 / 0.37 ms a step; 5 shook them
// (0.18 m/s; docs/contact.md).
#define OD_SELF_SWEEPS 10
// A sweep that moved no pair's ends by more than this (m) ends them.
#define OD_SELF_SETTLED 1e-6
// At most this many near pairs of one body get forces: their coupling is dense (pairs²) and each three of
// their particles cost a substitution once a step (od_SelfResponse).
#define OD_SELF_PAIRS 256

// The forces that hold the near pairs of one body at the centres of the next solve, as far as the response
// predicts them (projected Gauss-Seidel on the pairs' coupling, from the forces of the last solve): each pair's
// gap plus the change that its own and the other pairs' new forces make is >= 0, its normal force >= 0 and 0
// where the gap stays open; its friction force cancels its slip since the step's start with the same changes,
// within μ times its normal force (Coulomb: static friction over the whole step, as between bodies).
static void od_SolveForces(od_PairScratch* s, od_SelfSolve* q, double mu)
{
	int count = s->nearCount;
	for (int k = 0; k < count; ++k)
	{
		for (int l = k; l < count; ++l)
		{
			double c = od_PairResponse(q, s, &s->pairs[k], &s->pairs[l]);
			q->coupling[k * count + l] = c;
			q->coupling[l * count + k] = c;
		}
	}
	double change = INFINITY; // the most a sweep moved a pair's ends by its own force's change
	for (int sweep = 0; sweep < OD_SELF_SWEEPS && change > OD_SELF_SETTLED; ++sweep)
	{
		change = 0.0;
		for (int k = 0; k < count; ++k)
		{
			od_ContactPair* pair = &s->pairs[k];
			const double* row = q->coupling + (size_t)k * (size_t)count;
			if (!(row[k] > 0.0))
			{
				continue;
			}
			od_Vec3 before = od_PairForce(pair);
			od_Vec3 moved = od_V3(0, 0, 0); // how far the forces' changes move the pair's ends apart
			for (int l = 0; l < count; ++l)
			{
				moved = od_MulAdd(moved, row[l], od_Sub(od_PairForce(&s->pairs[l]), od_V3Load(q->applied + 3 * l)));
			}
			od_Vec3 n = od_V3Load(pair->n);
			pair->force = fmax(pair->force - (pair->gap + od_Dot(n, moved)) / row[k], 0.0);
			od_Vec3 slip = od_Add(od_V3Load(q->slip + 3 * k), moved);
			od_Vec3 t = od_MulAdd(od_V3Load(pair->tangent), -1.0 / row[k], slip);
			t = od_MulAdd(t, -od_Dot(t, n), n);
			double length = od_Length(t), limit = mu * pair->force;
			od_V3Store(pair->tangent, length > limit ? od_Scale(limit / length, t) : t);
			change = fmax(change, row[k] * od_Length(od_Sub(od_PairForce(pair), before)));
		}
	}
}

// After a solve of a step's iterations with self-contact: measures the near pairs (their gaps and slips) and
// sets their forces for the next solve (od_SolveForces).
static void od_UpdateSelfForces(od_PairScratch* s, od_Sim* sim, bool first)
{
	od_SelfSolve* q = s->self;
	od_CacheMoments(s, &sim, 1);
	for (int k = 0; k < s->nearCount; ++k)
	{
		od_ContactPair* pair = &s->pairs[k];
		od_End a = od_EndOf(s, &sim, pair->a), b = od_EndOf(s, &sim, pair->b);
		od_V3Store(q->applied + 3 * k, od_PairForce(pair));
		od_MeasureSelfPair(s, pair, &a, &b, &sim->selfDef, first);
		od_Vec3 n = od_V3Load(pair->n), rel = od_Sub(od_Sub(b.x1, b.x0), od_Sub(a.x1, a.x0));
		od_V3Store(q->slip + 3 * k, od_MulAdd(rel, -od_Dot(rel, n), n));
	}
	od_SolveForces(s, q, sim->selfDef.friction);
	od_ApplyForces(s, &sim, 1);
}

// How far beyond its path to the first solve's centre a particle's bounding sphere reaches in the broad phase
// after a step's first solve (od_NearSelfPairs): where no particle then moved farther, its pairs are those of
// the step's end too, and the projection takes them without a broad phase of its own (one broad phase a step
// instead of two: a 10,000-particle beam at rest with self-contact took 1.29 times the plain step with two,
// docs/contact.md).
static double od_SelfSlack(const od_Sim* sim)
{
	return sim->selfDef.thickness;
}

// Whether every particle of sim ended within od_SelfSlack of where the step's first solve put it (its path
// sphere's centre there, s->sphere, the midpoint of its start and that: od_Bin), so that the pairs found then
// hold every pair of the step's end.
static bool od_SelfPairsHold(const od_PairScratch* s, const od_Sim* sim)
{
	double slack = od_SelfSlack(sim);
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_Vec3 first = od_Sub(od_Scale(2.0, od_V3Load(s->sphere + 4 * i)), od_V3Load(sim->previous.x + 3 * i));
		od_Vec3 moved = od_Sub(od_V3Load(sim->state.x + 3 * i), first);
		if (od_Dot(moved, moved) > slack * slack)
		{
			return false;
		}
	}
	return true;
}

// The near pairs of one body after a step's first solve (their forces 0): a broad phase over the paths since
// the step's start (nothing is carried from step to step: a step stays a function of the state), then
// od_GatherNear. More than OD_SELF_PAIRS get none (the projection alone, as before the forces).
static od_Status od_NearSelfPairs(od_PairScratch* s, od_Sim* sim)
{
	od_Status status = od_NewPairs(s, &sim, 1, sim->selfDef.thickness + 2.0 * od_SelfSlack(sim), &sim->selfDef);
	s->nearCount = 0;
	if (status == OD_OK && s->pairCount > 0)
	{
		od_GatherNear(s, &sim, 1, &sim->selfDef);
	}
	s->nearCount = s->nearCount > OD_SELF_PAIRS ? 0 : s->nearCount;
	status = status == OD_OK && s->nearCount > 0 ? od_BodyContact_ReserveForces(sim) : status;
	status = status == OD_OK && s->nearCount > 0 ? od_SelfSolveReserve(s, sim->graph->n, s->nearCount) : status;
	return status == OD_OK && s->nearCount > 0 ? od_SelfParticles(s) : status;
}

// The iterations of a step of one simulation with self-contact: after the first solve, the pairs near then
// get forces that hold them in every later solve (see the top of the file). Without near pairs the step is
// the plain one, bit for bit.
static od_Status od_IterateSelf(od_PairScratch* s, od_Sim* sim, bool* found)
{
	bool more = true;
	od_Status status = od_Step_Advance(sim, &more);
	*found = status == OD_OK && more;
	status = *found ? od_NearSelfPairs(s, sim) : status;
	bool forces = status == OD_OK && more && s->nearCount > 0;
	if (forces)
	{
		od_Tolerance_PlainPlan(&sim->iteration.plan);
		od_SelfResponse(sim, s->self);
		od_UpdateSelfForces(s, sim, true);
	}
	while (more && status == OD_OK)
	{
		status = od_Step_Advance(sim, &more);
		if (status == OD_OK && forces && more)
		{
			od_UpdateSelfForces(s, sim, false);
		}
	}
	if (forces)
	{
		memset(sim->contactForce, 0, sizeof(double) * 3 * (size_t)sim->graph->n);
	}
	return status;
}

// Member b's bounding box at the step's start, its particles' reach included (s->box).
static void od_MemberBox(od_PairScratch* s, const od_Sim* sim, int b)
{
	double* box = s->box + 6 * b;
	for (int a = 0; a < 3; ++a)
	{
		box[a] = INFINITY;
		box[3 + a] = -INFINITY;
	}
	for (int i = 0; i < sim->graph->n; ++i)
	{
		double r = od_ContactReach(sim, i);
		for (int a = 0; a < 3; ++a)
		{
			box[a] = fmin(box[a], sim->state.x[3 * i + a] - r);
			box[3 + a] = fmax(box[3 + a], sim->state.x[3 * i + a] + r);
		}
	}
}

// Whether members b and c are farther apart than the larger of them is long (their boxes).
static bool od_FarApart(const od_PairScratch* s, int b, int c)
{
	const double *p = s->box + 6 * b, *q = s->box + 6 * c;
	double gap = 0.0, size = 0.0;
	for (int a = 0; a < 3; ++a)
	{
		gap = fmax(gap, fmax(p[a] - q[3 + a], q[a] - p[3 + a]));
		size = fmax(size, fmax(p[3 + a] - p[a], q[3 + a] - q[a]));
	}
	return gap > size;
}

// Which members step as they would alone (s->alone): with forces between the bodies, those farther from every
// other member than the larger of the two is long, with no pair carried from the last step and no self-contact.
// Their forces come only from such pairs (od_GatherNear takes its near pairs from them), so they have none this
// step, and they take their floor and colliders inside the iterations, their own start and their own tolerance,
// as alone. Before, every member of a group with forces iterated in step with the others, its floor after the
// iterations: a 1 m capsule dropped on the floor landed up to 5 cm otherwise with another body 5 m away in its
// group than alone, and in the add-on every object changed every other's simulation. Not as soon as no pair
// joins it: a Suzanne dropped 1 m onto another, the lower then taking the group's floor at the landing, knocked it
// over (the Suzanne tests of tests/test_addon_colliders.py).
static void od_MarkAlone(od_PairScratch* s, od_Sim* const* sims, int count, bool forces)
{
	for (int b = 0; b < count; ++b)
	{
		s->alone[b] = forces && !sims[b]->selfContact;
		if (forces)
		{
			od_MemberBox(s, sims[b], b);
		}
	}
	for (int b = 0; b < count; ++b)
	{
		for (int c = 0; c < b; ++c)
		{
			if ((s->alone[b] || s->alone[c]) && !od_FarApart(s, b, c))
			{
				s->alone[b] = s->alone[c] = false;
			}
		}
	}
	for (int k = 0; k < s->pairCount; ++k)
	{
		int a = s->body[s->pairs[k].a], b = s->body[s->pairs[k].b];
		if (a != b)
		{
			s->alone[a] = s->alone[b] = false;
		}
	}
}

od_Status od_BodyContact_Step(od_PairScratch* s, od_Sim* const* sims, int count, const od_BodyContactDef* between)
{
	// With forces between the bodies, each member starts from its previous rotations, takes plain pairs and
	// iterates in step with the others (od_IterateWithForces). Measured on a capsule dropped across a bar under
	// the default "auto" tolerance (Rubber, 1/60 s, 6 s): with the start od_Tolerance_ChooseStart picks (from a
	// global solve without the forces) the capsule rattled at 0.2-0.37 m/s and slid off in about 5 s; with
	// Chebyshev pairs, even at a fixed count, it slid off; a member that stopped at its tolerance did not see
	// the forces the others' later solves set. With all three changed it rests (0.011 m/s, 0.55 ms a step).
	bool forces = count > 1 && between->inIterations;
	od_MarkAlone(s, sims, count, forces);
	for (int k = 0; k < s->pairCount; ++k)
	{
		s->pairs[k].resting = forces && s->pairs[k].force > 0.0; // its slip in its first particle's frame (od_Turning)
	}
	for (int b = 0; b < count; ++b)
	{
		// The floor and colliders of a group's members with forces act after the iterations, as before issue 27:
		// inside them, their forces (from zero each step) beside the group's (carried from the last step) left
		// the upper of two stacked bars on the floor at 0.12 m/s after 6 s (0.013 with the projection).
		bool together = forces && !s->alone[b];
		sims[b]->surface.after = together;
		sims[b]->surface.rolls = OD_ROLL_NONE;
		od_Step_Start(sims[b], !together);
	}
	od_Status status = OD_OK;
	bool found = false; // self-contact's pairs found after the first solve (od_IterateSelf)
	if (forces)
	{
		status = od_IterateWithForces(s, sims, count, between);
	}
	else if (count == 1)
	{
		status = od_IterateSelf(s, sims[0], &found);
	}
	else // a group with contact after the iterations only: no forces
	{
		for (int b = 0; b < count && status == OD_OK; ++b)
		{
			bool more = true;
			while (more && status == OD_OK)
			{
				status = od_Step_Advance(sims[b], &more);
			}
		}
	}
	bool again = status == OD_OK && !(found && od_SelfPairsHold(s, sims[0]));
	status = again ? od_NewPairs(s, sims, count, od_Thickness(sims, count, between), between) : status;
	return status == OD_OK ? od_ProjectPairs(s, sims, count, between) : status;
}

od_Status od_Sim_SetSelfContact(od_Sim* sim, const od_BodyContactDef* def)
{
	od_Status status = def ? od_BodyContact_Check(def, true) : OD_OK;
	status = status == OD_OK && def ? od_PairScratch_Reserve(&sim->selfPairs, sim->graph->n) : status;
	if (status != OD_OK)
	{
		return status;
	}
	sim->selfContact = def != NULL;
	sim->selfDef = def ? *def : od_DefaultBodyContactDef();
	return OD_OK;
}

int od_Sim_GetSelfContact(const od_Sim* sim, od_BodyContactDef* def)
{
	if (def)
	{
		*def = sim->selfDef;
	}
	return sim->selfContact;
}

// Whether goals or position constraints hold sim (a rig's animation, a pin): its motion is theirs, which an impact
// does not slow (od_Part, od_Land): a member whose goals lifted it off the floor under another at 1 m/s (strength 0.5,
// 60 steps a second) was held to 0.16 m/s a step, and one leaving another was slowed and dragged it along.
static bool od_Driven(const od_Sim* sim)
{
	bool driven = sim->constraints.positionCount > 0;
	for (int i = 0; !driven && i < sim->graph->n; ++i)
	{
		driven = od_Goals_Hold(sim, i);
	}
	return driven;
}

void od_BodyContact_Keep(od_PairScratch* s, od_Sim* const* sims, int count)
{
	for (int b = 0, first = 0; b < count; first += sims[b++]->graph->n)
	{
		memcpy(s->kept + 3 * (size_t)first, sims[b]->state.x, sizeof(double) * 3 * (size_t)sims[b]->graph->n);
	}
}

// What the members' finish moved particle p (od_BodyContact_Keep).
static od_Vec3 od_Finished(const od_PairScratch* s, od_Sim* const* sims, int p)
{
	return od_Sub(od_V3Load(sims[s->body[p]]->state.x + 3 * s->local[p]), od_V3Load(s->kept + 3 * p));
}

// Member m's centre's height at the step's start; a NaN one (a state gone bad, which the call's end refuses) the
// lowest: compared as it is, it was below none and none below it, two members shared a storey and
// od_BodyContact_Carry looked for the missing one past the members (a segfault).
static double od_Height(const od_PairScratch* s, int m)
{
	double z = s->pose[13 * m + 2];
	return isnan(z) ? -INFINITY : z;
}

// How many members start the step with their centre below member m's (ties by index): the order of the carries.
static int od_Storey(const od_PairScratch* s, int count, int m)
{
	int below = 0;
	for (int b = 0; b < count; ++b)
	{
		double zb = od_Height(s, b), zm = od_Height(s, m);
		below += zb < zm || (zb == zm && b < m);
	}
	return below;
}

// Member u's carry (od_BodyContact_Carry): the mean, by force, of what the finish slid its comparable pairs' lower
// ends across their normals against their upper ends on u, over its pairs rising towards it (OD_HELD_RISE) where
// either member rolled on a patch.
static od_Vec3 od_CarryOf(const od_PairScratch* s, od_Sim* const* sims, int u)
{
	od_Vec3 sum = od_V3(0, 0, 0);
	double weight = 0.0;
	for (int k = 0; k < s->pairCount; ++k)
	{
		const od_ContactPair* pair = &s->pairs[k];
		int ma = s->body[pair->a], mb = s->body[pair->b];
		od_Vec3 n = od_V3Load(pair->n);
		bool up = mb == u && n.z > OD_HELD_RISE, down = ma == u && n.z < -OD_HELD_RISE;
		int lower = up ? ma : mb;
		if (!(up || down) || ma == mb || !(pair->force > 0.0) || !od_Comparable(s, pair) ||
			(sims[lower]->surface.rolls == OD_ROLL_NONE && sims[u]->surface.rolls == OD_ROLL_NONE))
		{
			continue;
		}
		od_Vec3 slid = up ? od_Sub(od_Finished(s, sims, pair->a), od_Finished(s, sims, pair->b))
						  : od_Sub(od_Finished(s, sims, pair->b), od_Finished(s, sims, pair->a));
		sum = od_MulAdd(sum, pair->force, od_MulAdd(slid, -od_Dot(slid, n), n));
		weight += pair->force;
	}
	sum.z = 0.0; // level: no work against gravity
	return weight > 0.0 ? od_Scale(1.0 / weight, sum) : sum;
}

// The patch rolls after the projections (od_PatchRolls, surface_contact.c) turn each member about its own patch:
// the lower of two stacked round members rolled back on its floor carried its top from under the upper one, which
// friction, inside the iterations, never saw (Rubber spheres at 24 steps a second, the lower settled first: the
// upper's contact particle slid 0.5 mm a step on the lower's, its friction at a fifth of its bound, and rolled off;
// docs/contact.md, "Stacks", stop 41). Each member resting on others is moved with them, rigidly (its velocities
// too), from the floor up (od_Storey), by what the finish slid them under it; not one goals or pins hold
// (od_Driven: its motion is theirs, and the rolls leave it alone).
void od_BodyContact_Carry(od_PairScratch* s, od_Sim* const* sims, int count)
{
	for (int m = 0; m < count; ++m)
	{
		s->storeys[od_Storey(s, count, m)] = m;
	}
	for (int storey = 1; storey < count; ++storey)
	{
		int u = s->storeys[storey];
		od_Vec3 carry = od_Driven(sims[u]) ? od_V3(0, 0, 0) : od_CarryOf(s, sims, u);
		od_Sim* sim = sims[u];
		for (int i = 0; od_Length(carry) > 0.0 && i < sim->graph->n; ++i)
		{
			od_V3Store(sim->state.x + 3 * i, od_Add(od_V3Load(sim->state.x + 3 * i), carry));
			od_V3Store(sim->state.v + 3 * i, od_MulAdd(od_V3Load(sim->state.v + 3 * i), 1.0 / sim->def.dt, carry));
		}
	}
}

// A sticking pair's anchor is kept in its end a's frame (od_Slip): at a step's end it turns as a's particle turned
// over the step, every pair's but a braced end's. Where the next step reads the slip in world coordinates
// (od_Turning: a pair that carried no force into it, self-contact pairs of a member, longer steps) the turned
// anchor is read as it stands, a mix kept on purpose: turned only where od_Turning turns, the Jelly spheres stacked
// at 60 steps a second (test_body_contact) moved at 0.074 m/s at 3 s. Its friction force stays in world coordinates: turned with the particle too, that of a Jelly sphere
// resting on another at 24 steps a second turned with its particle's wobble, and the upper one shook at 0.014 m/s.
void od_BodyContact_TurnAnchors(od_PairScratch* s, od_Sim* const* sims)
{
	for (int k = 0; k < s->pairCount; ++k)
	{
		od_ContactPair* pair = &s->pairs[k];
		od_End a = od_EndOf(s, sims, pair->a), b = od_EndOf(s, sims, pair->b);
		od_Brace(s, pair, &a, &b);
		od_Mat3 turned = od_Turned(&a);
		od_V3Store(pair->anchor, od_M3MulV(&turned, od_V3Load(pair->anchor)));
	}
}

// Inelastic impacts between members (od_BodyContact_Impacts): passes over the interfaces and both their members'
// grounds, Gauss-Seidel (each part taken moves what the next sees), as many as the projection's (OD_PAIR_PASSES).
#define OD_IMPACT_PASSES OD_PAIR_PASSES

// Adds dv to the velocity of every particle of sim: its momentum changes by its mass times dv, nothing turns or
// strains.
static void od_ShiftVelocity(od_Sim* sim, od_Vec3 dv)
{
	for (int i = 0; i < sim->graph->n; ++i)
	{
		od_V3Store(sim->state.v + 3 * i, od_Add(od_V3Load(sim->state.v + 3 * i), dv));
	}
}

// The interfaces at the step's end: the pairs that carry a force (the next step's warm start) between comparable
// members that meet each other with their ellipsoids (od_MembersOnEllipsoids), grouped by their members, each
// interface's normal the sum of its pairs' normals times their forces. The list grows as od_Interfaces' does,
// only when more members meet than ever before (reserving every pair of members would size od_Coarse's dense
// system by their square); out of memory fails the step, as an impact left out would let a member bounce.
static od_Status od_ImpactInterfaces(od_PairScratch* s, od_Sim* const* sims)
{
	s->interfaceCount = 0;
	for (int k = 0; k < s->pairCount; ++k)
	{
		const od_ContactPair* pair = &s->pairs[k];
		int ma = s->body[pair->a], mb = s->body[pair->b];
		bool ellipsoids = od_MembersOnEllipsoids(sims[ma]) && od_MembersOnEllipsoids(sims[mb]);
		if (ma == mb || !ellipsoids || pair->force <= 0.0 || !od_Comparable(s, pair))
		{
			continue;
		}
		int e = od_InterfaceOf(s, ma, mb);
		if (e < 0)
		{
			return od_Fail(OD_ERROR_MEMORY, "out of memory for the contact interfaces of %d pairs", s->pairCount);
		}
		od_Interface* ie = &s->interfaces[e];
		od_V3Store(ie->n, od_MulAdd(od_V3Load(ie->n), pair->force, od_V3Load(pair->n)));
	}
	return OD_OK;
}

// Interface ie's members parting along its normal faster than `speed`: their relative velocity along it slowed to
// `speed`, the change split by mass (momentum kept, kinetic energy lost).
static void od_Part(const od_PairScratch* s, od_Sim* const* sims, const od_Interface* ie, double speed)
{
	int l = ie->lower, u = ie->upper;
	if (od_Driven(sims[l]) || od_Driven(sims[u]))
	{
		return;
	}
	od_Vec3 n = od_Unit(od_V3Load(ie->n));
	od_Vec3 vu = od_MemberMean(s, sims[u], u, sims[u]->state.v), vl = od_MemberMean(s, sims[l], l, sims[l]->state.v);
	double w = od_Dot(od_Sub(vu, vl), n);
	if (w > speed)
	{
		double share = s->mass[l] / (s->mass[l] + s->mass[u]);
		od_ShiftVelocity(sims[u], od_Scale(-(w - speed) * share, n));
		od_ShiftVelocity(sims[l], od_Scale((w - speed) * (1.0 - share), n));
	}
}

// Whether a particle of sim is within `margin` of its floor (od_FloorDepth) or of a collider's thickness plus its
// reach (od_ColliderDepthBound) at the step's end.
static bool od_AtGround(const od_Sim* sim, double margin)
{
	bool at = false;
	for (int i = 0; !at && i < sim->graph->n; ++i)
	{
		const double* x = sim->state.x + 3 * i;
		at = sim->hasFloor && od_FloorDepth(sim, i, sim->state.R + 9 * i, x) > -margin;
		for (int k = 0; !at && k < sim->colliders.count; ++k)
		{
			od_Centre centre = od_ColliderCentre(&sim->colliders.items[k], od_V3Load(x));
			at = od_ColliderDepthBound(sim, &sim->colliders.items[k], i, &centre) > -margin;
		}
	}
	return at;
}

// Member b of an interface with a comparable one, meeting its floor with its skin (od_FloorSkinOnly: a floor that
// holds it inside the iterations gives back what this takes, the top of the file), pressed onto its floor by the
// pairs (s->load[b] < 0, as od_Rolls reads it) and free of goals and pins (od_Driven), leaving its ground (the floor
// or a collider it touched within the step: `thickness` plus its rise in the step) upwards (against gravity) faster
// than `speed`: its rise slowed to `speed`, as the floor's projection stops a lone body.
static void od_Land(const od_PairScratch* s, od_Sim* const* sims, int b, double speed, double thickness)
{
	if (s->load[b] >= 0.0 || od_Driven(sims[b]) || !od_FloorSkinOnly(sims[b]))
	{
		return;
	}
	const double* g = sims[b]->def.gravity;
	od_Vec3 up = od_Unit(od_V3(-g[0], -g[1], -g[2]));
	double rise = od_Dot(od_MemberMean(s, sims[b], b, sims[b]->state.v), up);
	if (rise > speed && od_AtGround(sims[b], thickness + rise * sims[b]->def.dt))
	{
		od_ShiftVelocity(sims[b], od_Scale(speed - rise, up));
	}
}

od_Status od_BodyContact_Impacts(od_PairScratch* s, od_Sim* const* sims, int count, const od_BodyContactDef* between)
{
	if (count < 2 || !between->inIterations)
	{
		return OD_OK; // no forces, no interfaces (nor s->mass)
	}
	od_Status status = od_ImpactInterfaces(s, sims);
	if (status != OD_OK)
	{
		return status;
	}
	const double* g = sims[0]->def.gravity;
	double speed = sqrt(g[0] * g[0] + g[1] * g[1] + g[2] * g[2]) * fmax(sims[0]->def.dt, OD_CLIMB_TIME);
	for (int pass = 0; pass < OD_IMPACT_PASSES && speed > 0.0 && s->interfaceCount > 0; ++pass)
	{
		for (int e = 0; e < s->interfaceCount; ++e)
		{
			od_Part(s, sims, &s->interfaces[e], speed);
		}
		for (int e = 0; e < s->interfaceCount; ++e)
		{
			od_Land(s, sims, s->interfaces[e].lower, speed, between->thickness);
			od_Land(s, sims, s->interfaces[e].upper, speed, between->thickness);
		}
	}
	return OD_OK;
}
