// A perceptual ramp for counts (black → blue → cyan → green → yellow → red), as in seed 001's
// ray-count heat maps (Figure 5.2).
#ifndef HEATMAP_GLSL
#define HEATMAP_GLSL

vec3 heatmap(float t) {
    t = clamp(t, 0.0, 1.0);
    const vec3 stops[6] = vec3[6](vec3(0.0), vec3(0.0, 0.0, 1.0), vec3(0.0, 1.0, 1.0), vec3(0.0, 1.0, 0.0), vec3(1.0, 1.0, 0.0), vec3(1.0, 0.0, 0.0));
    float x = t * 5.0;
    int i = min(int(x), 4);
    return mix(stops[i], stops[i + 1], x - float(i));
}

#endif
