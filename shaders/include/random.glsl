// Hashes and uniform numbers for stochastic passes (particles' launches, soft shadows' points on
// a light).
#ifndef RANDOM_GLSL
#define RANDOM_GLSL

// PCG's output permutation of an LCG step (Jarzynski and Olano 2020, "Hash Functions for GPU
// Rendering"): a well-mixed 32-bit hash.
uint pcg_hash(uint v) {
    uint state = v * 747796405u + 2891336453u;
    uint word = ((state >> ((state >> 28u) + 4u)) ^ state) * 277803737u;
    return (word >> 22u) ^ word;
}

// A uniform number in [0, 1) from `seed`, which moves on.
float random01(inout uint seed) {
    seed = pcg_hash(seed);
    return float(seed >> 8u) * (1.0 / 16777216.0);
}

#endif
