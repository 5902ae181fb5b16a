/* The C ABI end to end: load the built-in model, seed from examples/walk_seed.bvh, step 250 poses,
 * check every quaternion is finite and unit length, switch the action, and take the error path
 * with a missing file. Built and run by .ci/run (from the repository root):
 *
 *   cargo build --release -p motion-ffi
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
