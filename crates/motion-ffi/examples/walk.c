/* The C ABI end to end: load the built-in model, seed from examples/walk_seed.bvh, step 250 poses,
 * check every quaternion is finite and unit length, switch the action, and take the error path
 * with a missing file. Built and run by .ci/run (from the repository root):
 *
 *   cargo build --release -p motion-ffi
 * Then drives a character's own rig (23 Unreal-named joints given as arrays) with motion_rig_pose.
 *
 *   cc crates/motion-ffi/examples/walk.c -I crates/motion-ffi/include \
 *      target/release/libmotion_ffi.a -lpthread -ldl -lm -o target/walk && target/walk
 */
#define _POSIX_C_SOURCE 199309L
#include <math.h>
#include <stdio.h>
#include <string.h>
#include <time.h>

#include "motion.h"

static int fail(const char *what) {
    fprintf(stderr, "walk.c: %s: %s\n", what, motion_last_error());
    return 1;
}

int main(void) {
    motion_model *model = motion_model_default();
    if (!model) return fail("motion_model_default");
    size_t joints = motion_model_joint_count(model);
    printf("model: %zu joints (joint 0 %s, joint 17 %s); walking is action %d\n", joints,
           motion_model_joint_name(model, 0), motion_model_joint_name(model, 17),
           motion_model_action_index(model, "walking"));

    motion_generator *gen = motion_generator_new(model, 7);
    if (!gen) return fail("motion_generator_new");
    if (motion_generator_start_bvh(gen, "examples/walk_seed.bvh", "walking") != MotionStatus_Ok)
        return fail("motion_generator_start_bvh");

    float root[3], rotation[4], rotations[4 * 64];
    if (joints > 64) return fail("too many joints for this example");
    struct timespec t0, t1;
    clock_gettime(CLOCK_MONOTONIC, &t0);
    for (int k = 0; k < 250; k++) {
        if (k == 125 && motion_generator_set_action(gen, "eating") != MotionStatus_Ok)
            return fail("motion_generator_set_action");
        if (motion_generator_step_pose(gen, root, rotation, rotations, joints) != MotionStatus_Ok)
            return fail("motion_generator_step_pose");
        for (size_t j = 0; j <= joints; j++) {
            const float *q = j == joints ? rotation : rotations + 4 * j;
            float n = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
            if (!isfinite(n) || fabsf(n - 1.0f) > 1e-4f) {
                fprintf(stderr, "walk.c: pose %d joint %zu: |q| = %f\n", k, j, n);
                return 1;
            }
        }
        if (!isfinite(root[0]) || !isfinite(root[1]) || !isfinite(root[2])) {
            fprintf(stderr, "walk.c: pose %d: root not finite\n", k);
            return 1;
        }
    }
    clock_gettime(CLOCK_MONOTONIC, &t1);
    double us = ((t1.tv_sec - t0.tv_sec) * 1e9 + (t1.tv_nsec - t0.tv_nsec)) / 1e3 / 250;
    printf("250 poses, all unit quaternions; root at (%.2f, %.2f, %.2f) m; %.1f us per pose\n",
           root[0], root[1], root[2], us);

    /* The seed's floor the poses stand on (the world the seed was given in, for engines that
     * place the character there). */
    float level[4], pivot[3], tilt;
    if (motion_generator_floor(gen, level, pivot, &tilt) != MotionStatus_Ok)
        return fail("motion_generator_floor");
    printf("seed floor: tilt %.2f degrees, pivot (%.2f, %.2f, %.2f) m\n", tilt, pivot[0], pivot[1], pivot[2]);

    /* The character's own rig: an Unreal-named skeleton given as arrays (metres, +y up, facing +z,
     * identity rest rotations but the pelvis turned 90 degrees about x, as exporters do), and
     * the local rotations to copy into its bones for the current pose. */
    const char *rig_names[23] = {"root", "pelvis", "spine_01", "spine_02", "spine_03", "neck_01",
                                 "head", "clavicle_l", "upperarm_l", "lowerarm_l", "hand_l",
                                 "clavicle_r", "upperarm_r", "lowerarm_r", "hand_r", "thigh_l",
                                 "calf_l", "foot_l", "ball_l", "thigh_r", "calf_r", "foot_r", "ball_r"};
    const int32_t parents[23] = {-1, 0, 1, 2, 3, 4, 5, 4, 7, 8, 9, 4, 11, 12, 13,
                                 1, 15, 16, 17, 1, 19, 20, 21};
    /* Rest translations in each parent's frame. The pelvis' rest rotation (-90 degrees about x)
     * turns the frame of everything below it: there up is +z, forward -y, left +x. */
    const float tr[23][3] = {
        {0, 0, 0},          {0, 0.96f, 0},      {0, 0, 0.11f},      {0, 0, 0.14f},
        {0, 0, 0.14f},      {0, 0, 0.16f},      {0, 0, 0.10f},      {0.06f, 0, 0.12f},
        {0.14f, 0, 0},      {0.20f, 0, -0.20f}, {0.18f, 0, -0.18f}, {-0.06f, 0, 0.12f},
        {-0.14f, 0, 0},     {-0.20f, 0, -0.20f}, {-0.18f, 0, -0.18f}, {0.09f, 0, -0.05f},
        {0, 0, -0.43f},     {0, 0, -0.42f},     {0, -0.12f, -0.08f}, {-0.09f, 0, -0.05f},
        {0, 0, -0.43f},     {0, 0, -0.42f},     {0, -0.12f, -0.08f}};
    float rest_rot[4 * 23], rest_tr[3 * 23];
    for (int j = 0; j < 23; j++) {
        float s = j == 1 ? -0.70710678f : 0.0f, c = j == 1 ? 0.70710678f : 1.0f;
        rest_rot[4 * j + 0] = s; rest_rot[4 * j + 1] = 0; rest_rot[4 * j + 2] = 0; rest_rot[4 * j + 3] = c;
        for (int k = 0; k < 3; k++) rest_tr[3 * j + k] = tr[j][k];
    }
    motion_rig *rig = motion_rig_new(gen, rig_names, parents, rest_rot, rest_tr, 23, NULL);
    if (!rig) return fail("motion_rig_new");
    float rig_rotations[4 * 23], hips[3];
    for (int k = 0; k < 25; k++) {
        if (motion_generator_step_pose(gen, root, rotation, rotations, joints) != MotionStatus_Ok)
            return fail("motion_generator_step_pose");
        if (motion_rig_pose(rig, gen, rig_rotations, 23, hips) != MotionStatus_Ok)
            return fail("motion_rig_pose");
        for (int j = 0; j < 23; j++) {
            const float *q = rig_rotations + 4 * j;
            float n = sqrtf(q[0] * q[0] + q[1] * q[1] + q[2] * q[2] + q[3] * q[3]);
            if (!isfinite(n) || fabsf(n - 1.0f) > 1e-4f) {
                fprintf(stderr, "walk.c: rig pose %d joint %d: |q| = %f\n", k, j, n);
                return 1;
            }
        }
    }
    int h = motion_rig_hips(rig);
    printf("rig: hips joint %d (%s) at (%.2f, %.2f, %.2f) m in its parent; thigh_l rotation (%.3f, %.3f, %.3f, %.3f)\n",
           h, rig_names[h], hips[0], hips[1], hips[2], rig_rotations[4 * 15], rig_rotations[4 * 15 + 1],
           rig_rotations[4 * 15 + 2], rig_rotations[4 * 15 + 3]);
    if (h != 1 || !(hips[1] > 0.5f && hips[1] < 1.2f)) {
        fprintf(stderr, "walk.c: the hips are not at a standing height: %f\n", hips[1]);
        return 1;
    }
    motion_rig_free(rig);

    /* The error path: a missing file is a negative status and a message naming it. */
    int status = motion_generator_start_bvh(gen, "no/such/seed.bvh", "walking");
    if (status != MotionStatus_BadInput || !strstr(motion_last_error(), "no/such/seed.bvh")) {
        fprintf(stderr, "walk.c: a missing file gave %d: %s\n", status, motion_last_error());
        return 1;
    }
    printf("missing file: status %d, \"%s\"\n", status, motion_last_error());
    if (motion_model_load("no/such/model.safetensors") != NULL) return 1;
    if (motion_model_action_index(model, "moonwalk") >= 0) return 1;

    motion_generator_free(gen);
    motion_model_free(model);
    return 0;
}
