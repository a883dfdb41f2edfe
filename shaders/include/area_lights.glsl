// One-sided area lights, rectangles and disks (issue 52, item 1; engine::light::RectLight and
// DiskLight), shaded from their shape rather than from a point.
// - Diffuse: the clamped cosine integrated exactly over the light's polygon as the point sees it,
//   clipped to the point's horizon: linearly transformed cosines with the identity transform
//   (Heitz, Dupuy, Hill and Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly
//   Transformed Cosines", §4: the polygon's edge integral, Lambert's formula). A disk is the
//   regular polygon of AREA_DISK_SIDES sides of its area.
// - Specular: the same integral over the polygon transformed by the inverse of the linearly
//   transformed cosine fitted to our GGX lobe (Heitz et al. 2016, §5), times the lobe's
//   magnitude with Fresnel; both from the fitted table TEXTURE_LTC (render::lights::ltc,
//   fitted by render/examples/ltc_fit.rs).
// The record (GpuLight): `direction` the facing, spot_scale/spot_offset/cone_cos an axis in the
// plane (a rectangle's half-width vector, a disk's unit axis), `size` the half height or radius.
#ifndef AREA_LIGHTS_GLSL
#define AREA_LIGHTS_GLSL

#include "scene.glsl"
#include "brdf.glsl"

// A disk's polygon: 16 sides, their radius scaled so that the polygon's area is the disk's
// (the form factor then differs from the disk's by far less than a percent at any distance).
const int AREA_DISK_SIDES = 16;

// Whether this pipeline keeps the area lights' code (a specialization constant, true unless the
// pipeline says otherwise): the shading passes are made without it while the scene has no area
// light (render::gpu::pipeline::Specialization). Every area-light branch tests is_area_light,
// so without it they all fold away (a rect or disk light would then shade as a point light:
// such pipelines serve only scenes without them).
layout(constant_id = SPEC_AREA_LIGHTS) const bool AREA_LIGHTS = true;

bool is_area_light(GpuLight light) {
    return AREA_LIGHTS && (light.kind == LIGHT_RECT || light.kind == LIGHT_DISK);
}

// The axis in the light's plane (a rectangle's half-width vector, a disk's unit axis) and the
// other axis, of the half height's or the radius's length.
vec3 area_right(GpuLight light) {
    return vec3(light.spot_scale, light.spot_offset, light.cone_cos);
}

vec3 area_up(GpuLight light) {
    return normalize(cross(area_right(light), light.direction)) * light.size;
}

float area_of(GpuLight light) {
    return light.kind == LIGHT_RECT ? 4.0 * length(area_right(light)) * light.size : PI * light.size * light.size;
}

// Whether `p` lies on the side the light emits to.
bool area_faces(GpuLight light, vec3 p) {
    return dot(light.direction, p - light.position) > 0.0;
}

// The point of the light's shape at local coordinates `uv` in [-1, 1]² (a rectangle's), or the
// disk's point nearest to them.
vec3 area_point(GpuLight light, vec2 uv) {
    vec3 right = light.kind == LIGHT_RECT ? area_right(light) : normalize(area_right(light)) * light.size;
    if (light.kind == LIGHT_DISK && dot(uv, uv) > 1.0) uv = normalize(uv);
    return light.position + right * uv.x + area_up(light) * uv.y;
}

// Where a shadow ray to a point of the light's face at distance `d` stops: just short of it, so
// that the ceiling or wall a panel is mounted flush on does not block it (a mesh placed at the
// light itself, in front of its face, still does).
// A point within the rays' tmin (1 mm) of the face sees it unblocked (a ray as long as tmin, as
// a point inside a sphere light has).
float area_ray_end(float d) {
    return max(d - max(1e-3, 1e-4 * d), 1e-3);
}

// A point spread uniformly over the light's face by `u` in [0, 1)² (the soft shadows' rays).
// The rays sample the whole face, also a part below the receiver's horizon (shading clips it
// away): a ray there is blocked by the receiver, so such a light's shadow is a little darker.
vec3 area_sample(GpuLight light, vec2 u) {
    if (light.kind == LIGHT_RECT) return area_point(light, u * 2.0 - 1.0);
    float r = sqrt(u.x), phi = 2.0 * PI * u.y;
    return area_point(light, r * vec2(cos(phi), sin(phi)));
}

// The light's polygon seen from a point: its centre relative to the point, its two half axes
// (a disk's scaled so that its 16-gon has the disk's area) and its corner count.
struct AreaPolygon {
    vec3 centre;
    vec3 right;
    vec3 up;
    int corners;
};

AreaPolygon area_polygon(GpuLight light, vec3 p) {
    AreaPolygon g;
    g.centre = light.position - p;
    g.up = area_up(light);
    if (light.kind == LIGHT_RECT) {
        g.right = area_right(light);
        g.corners = 4;
    } else {
        // A regular polygon's area is n/2 · r² · sin(2π/n): scaled to πR².
        float scale = sqrt(PI / (0.5 * float(AREA_DISK_SIDES) * sin(2.0 * PI / float(AREA_DISK_SIDES))));
        g.right = normalize(area_right(light)) * light.size * scale;
        g.up *= scale;
        g.corners = AREA_DISK_SIDES;
    }
    return g;
}

// Corner `i` of the polygon, in order around it.
vec3 area_corner(AreaPolygon g, int i) {
    if (g.corners == 4) {
        vec2 s = vec2(i == 1 || i == 2 ? 1.0 : -1.0, i >= 2 ? 1.0 : -1.0);
        return g.centre + g.right * s.x + g.up * s.y;
    }
    float a = 2.0 * PI * float(i) / float(g.corners);
    return g.centre + g.right * cos(a) + g.up * sin(a);
}

// The polygon with every corner transformed by `to` (its corners are linear in its centre and
// axes, so transforming those three transforms them all).
AreaPolygon area_transformed(AreaPolygon g, mat3 to) {
    g.centre = to * g.centre;
    g.right = to * g.right;
    g.up = to * g.up;
    return g;
}

// Lambert's term of the edge from corner `a` to corner `b` (directions from the point): the arc
// between them times the unit normal of their plane, whose sum over a polygon's edges is its
// vector form factor × 2π. The arc over the sine, θ / sin θ, comes from the cosine by the
// rational fit of Heitz and Hill's LTC code (2017) for an acute angle, within 1.5e-6 of it
// relatively (measured), cheaper than an inverse tangent; an obtuse angle's is π / sin θ less
// the fit's at π − θ, its sine the cross product's length, which stays accurate as θ nears π
// (where 1 − cos²θ does not in single precision).
vec3 edge_term(vec3 a, vec3 b) {
    a = normalize(a);
    b = normalize(b);
    vec3 c = cross(a, b);
    float x = dot(a, b);
    float y = abs(x);
    // θ / (2π sin θ) for the acute angle.
    float acute = (0.8543985 + (0.4965155 + 0.0145206 * y) * y) / (3.4175940 + (4.1616724 + y) * y);
    float over_sin = x > 0.0 ? acute : 0.5 * inversesqrt(max(dot(c, c), 1e-14)) - acute;
    return c * (2.0 * PI * over_sin);
}

// The form factor of the polygon `g` (its corners relative to the point) over normal `n`: its
// cosine-weighted solid angle divided by π (1 for a polygon filling the hemisphere). The polygon
// is clipped to the horizon (Sutherland–Hodgman against n·x ≥ 0) as its corners stream by, each
// kept or cut corner adding the edge from the last one, so that no corner is stored (with arrays
// of corners the corridor's visibility-buffer shading on the H200 took 0.70 ms, 0.51 without).
// `towards` is the vector form factor's direction: where the light comes from on average (the
// clipped part's, where the horizon cuts it). The winding as seen from the point decides the
// sign, which the one-sided test has already settled.
float polygon_form_factor(AreaPolygon g, vec3 n, out vec3 towards) {
    vec3 sum = vec3(0.0), first = vec3(0.0), last = vec3(0.0);
    bool started = false;
    vec3 a = area_corner(g, 0);
    float da = dot(n, a);
    for (int i = 0; i < g.corners; ++i) {
        vec3 b = area_corner(g, i + 1 == g.corners ? 0 : i + 1);
        float db = dot(n, b);
        for (int k = 0; k < 2; ++k) {
            // The corner a where it is above the horizon, then where the edge crosses it.
            bool keep = k == 0 ? da >= 0.0 : (da >= 0.0) != (db >= 0.0);
            if (!keep) continue;
            vec3 q = k == 0 ? a : mix(a, b, da / (da - db));
            if (started) sum += edge_term(last, q);
            else first = q;
            last = q;
            started = true;
        }
        a = b;
        da = db;
    }
    if (started) sum += edge_term(last, first);
    float form = dot(n, sum);
    towards = sum * sign(form);
    towards = dot(towards, towards) > 0.0 ? normalize(towards) : n;
    return abs(form) * (0.5 / PI);
}

// The LTC table, bilinear between its cells, for perceptual roughness `roughness` and view
// cosine `n_dot_v`; `half_` picks the half: 0 the inverse matrix's (a, b, c, d), 1 the
// lobe's magnitude (render::lights::ltc has the layout).
vec4 ltc_lookup(float roughness, float n_dot_v, int half_) {
    vec2 cell = clamp(vec2(sqrt(max(1.0 - n_dot_v, 0.0)), roughness), 0.0, 1.0) * float(LTC_SIZE - 1u);
    ivec2 lo = min(ivec2(cell), ivec2(int(LTC_SIZE) - 2));
    vec2 f = cell - vec2(lo);
    lo.x += half_ * int(LTC_SIZE);
    vec4 t00 = texelFetch(textures[TEXTURE_LTC], lo, 0), t10 = texelFetch(textures[TEXTURE_LTC], lo + ivec2(1, 0), 0);
    vec4 t01 = texelFetch(textures[TEXTURE_LTC], lo + ivec2(0, 1), 0), t11 = texelFetch(textures[TEXTURE_LTC], lo + ivec2(1, 1), 0);
    return mix(mix(t00, t10, f.x), mix(t01, t11, f.x), f.y);
}

// The share of the GGX lobe (normalised to 1) that the light's polygon `g` covers, for normal
// `n`, view `v` and perceptual roughness `roughness`: the polygon in the shading frame (x along
// the view's tangent, z the normal), transformed by the lobe's inverse LTC and integrated as a
// clamped cosine (Heitz et al. 2016, §4–5).
float area_ltc_share(AreaPolygon g, vec3 n, vec3 v, float roughness, float n_dot_v) {
    vec3 t1 = v - n * dot(n, v);
    t1 = dot(t1, t1) > 1e-10 ? normalize(t1) : normalize(cross(n, abs(n.x) < 0.9 ? vec3(1.0, 0.0, 0.0) : vec3(0.0, 1.0, 0.0)));
    vec3 t2 = cross(n, t1);
    vec4 m = ltc_lookup(roughness, n_dot_v, 0);
    // GLSL's mat3 takes columns: M⁻¹ = [[a, 0, b], [0, c, 0], [d, 0, 1]].
    mat3 inverse_ltc = mat3(vec3(m.x, 0.0, m.w), vec3(0.0, m.z, 0.0), vec3(m.y, 0.0, 1.0));
    AreaPolygon lobe = area_transformed(g, inverse_ltc * transpose(mat3(t1, t2, n)));
    // Clipped where the transformed cosine ends, z' ≥ 0, as Heitz et al. do; the cosine reaches
    // a little below the surface's own horizon there, where the lobe is nothing, so a light the
    // horizon cuts (a panel standing on the floor) reflects somewhat too much. Clipping to that
    // horizon as well, (−d, 0, a)·x' ≥ 0 in the transformed space, took the test's rectangle
    // from 51 % to 36 % and cost the corridor's shading half as much again on the H200
    // (docs/experiments/area-lights-ltc-table.md).
    vec3 towards;
    return polygon_form_factor(lobe, vec3(0.0, 0.0, 1.0), towards);
}

// The radiance reflected towards `v` from an area light of radiance `light.color` that `p`
// sees in front of it (the caller applies the range window), for the surface `s` with normal
// `n`, without shadow.
// - Diffuse: the renormalised Disney factor taken towards where the light comes from on
//   average, by the exact form factor.
// - Specular: the share of the GGX lobe the face covers (area_ltc_share) times what the whole
//   lobe reflects with Schlick's Fresnel (the table's scale and bias of F0).
vec3 area_light_brdf(GpuLight light, SurfaceBrdf s, vec3 p, vec3 n, vec3 v) {
    vec3 towards;
    AreaPolygon g = area_polygon(light, p);
    float form = polygon_form_factor(g, n, towards);
    if (!(form > 0.0)) return vec3(0.0);
    float n_dot_v = min(abs(dot(n, v)) + 1e-5, 1.0);
    vec3 hd = normalize(v + towards);
    float fd = fd_disney_renormalized(n_dot_v, clamp(dot(n, towards), 0.0, 1.0), clamp(dot(towards, hd), 0.0, 1.0), s.roughness);
    vec3 diffuse = s.diffuse_color * fd * form;
    vec2 magnitude = ltc_lookup(s.roughness, n_dot_v, 1).xy;
    vec3 specular = (s.f0 * magnitude.x + magnitude.y) * area_ltc_share(g, n, v, s.roughness, n_dot_v);
    return (diffuse + specular) * light.color;
}

#endif
