// One-sided area lights, rectangles and disks (issue 52, item 1; engine::light::RectLight and
// DiskLight), shaded from their shape rather than from a point.
// - Diffuse: the clamped cosine integrated exactly over the light's polygon as the point sees it,
//   clipped to the point's horizon: linearly transformed cosines with the identity transform
//   (Heitz, Dupuy, Hill and Neubelt 2016, "Real-Time Polygonal-Light Shading with Linearly
//   Transformed Cosines", §4: the polygon's edge integral, Lambert's formula). A disk is the
//   regular polygon of AREA_DISK_SIDES sides of its area.
// - Specular: the most representative point (Karis 2013, "Real Shading in Unreal Engine 4",
//   area lights): the point of the shape nearest the mirror direction, where the GGX lobe peaks,
//   weighs the light's cosine-weighted solid angle, and a light wider than the lobe reflects no
//   more than the share of the lobe it spans (area_light_brdf). LTC's fitted GGX tables would
//   be closer for glossy surfaces; this needs no table.
// The record (GpuLight): `direction` the facing, spot_scale/spot_offset/cone_cos an axis in the
// plane (a rectangle's half-width vector, a disk's unit axis), `size` the half height or radius.
#ifndef AREA_LIGHTS_GLSL
#define AREA_LIGHTS_GLSL

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

// Lambert's term of the edge from corner `a` to corner `b` (directions from the point): the arc
// between them times the unit normal of their plane, whose sum over a polygon's edges is its
// vector form factor × 2π.
vec3 edge_term(vec3 a, vec3 b) {
    a = normalize(a);
    b = normalize(b);
    vec3 c = cross(a, b);
    float s = length(c);
    return s > 1e-7 ? c * (atan(s, dot(a, b)) / s) : vec3(0.0);
}

// The light's form factor seen from `p` over normal `n`: its cosine-weighted solid angle
// divided by π (1 for a light filling the hemisphere). The polygon is clipped to the horizon
// (Sutherland–Hodgman against n·x ≥ 0) as its corners stream by, each kept or cut corner
// adding the edge from the last one, so that no corner is stored (with arrays of corners the
// corridor's visibility-buffer shading on the H200 took 0.70 ms, 0.51 without). `towards` is
// the vector form factor's direction: where the light comes from on average (the clipped
// part's, where the horizon cuts it). The winding as seen from the point decides the sign,
// which the one-sided test has already settled.
float area_form_factor(GpuLight light, vec3 p, vec3 n, out vec3 towards) {
    AreaPolygon g = area_polygon(light, p);
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

// The point of the light's shape nearest the mirror direction `r` from `p`: where the ray meets
// the light's plane, clamped to the shape; a ray that turns away from the plane aims at the
// shape's point nearest where it heads.
vec3 area_representative_point(GpuLight light, vec3 p, vec3 r) {
    float towards = -dot(r, light.direction);
    float height = dot(light.direction, p - light.position);
    vec3 hit = towards > 1e-4 ? p + r * (height / towards) : p + r * 1e4;
    vec3 local = hit - light.position;
    vec3 right = area_right(light), up = area_up(light);
    // In the shape's units: half widths and half heights, or radii (a disk's axis is a unit vector).
    float across = light.kind == LIGHT_RECT ? dot(right, right) : light.size;
    vec2 uv = vec2(dot(local, right) / across, dot(local, up) / dot(up, up));
    return area_point(light, light.kind == LIGHT_RECT ? clamp(uv, -1.0, 1.0) : uv);
}

// The share of GGX's distribution of normals (D·(n·h), alpha `alpha`) within `tan_theta` of its
// peak: its cumulative distribution, tan²θ / (α² + tan²θ).
float ggx_share_within(float tan_theta, float alpha) {
    float t2 = tan_theta * tan_theta;
    return t2 / (alpha * alpha + t2);
}

// The radiance reflected towards `v` from an area light of radiance `light.color` that `p`
// sees in front of it (the caller applies the range window), for the surface `s` with normal
// `n`, without shadow.
// - Diffuse: the renormalised Disney factor taken towards where the light comes from on
//   average, by the exact form factor.
// - Specular: the lobe's value at the most representative point over the light's
//   cosine-weighted solid angle, which is exact while the lobe is wider than the light; a light
//   wider than the lobe reflects no more than the share of the lobe's normals it spans (seen as
//   a cone of its solid angle, half of it in normals, centred on the lobe) of what the whole
//   lobe reflects (the split sum's env_brdf_approx).
vec3 area_light_brdf(GpuLight light, SurfaceBrdf s, vec3 p, vec3 n, vec3 v) {
    vec3 towards;
    float form = area_form_factor(light, p, n, towards);
    if (!(form > 0.0)) return vec3(0.0);
    float n_dot_v = min(abs(dot(n, v)) + 1e-5, 1.0);
    vec3 hd = normalize(v + towards);
    float fd = fd_disney_renormalized(n_dot_v, clamp(dot(n, towards), 0.0, 1.0), clamp(dot(towards, hd), 0.0, 1.0), s.roughness);
    vec3 diffuse = s.diffuse_color * fd * form;
    vec3 ls = normalize(area_representative_point(light, p, reflect(-v, n)) - p);
    float n_dot_l = dot(n, ls);
    vec3 specular = vec3(0.0);
    if (n_dot_l > 0.0) {
        vec3 h = normalize(v + ls);
        vec3 f = f_schlick(s.f0, 1.0, clamp(dot(ls, h), 0.0, 1.0));
        float normals = d_ggx(clamp(dot(n, h), 0.0, 1.0), s.alpha);
        float lobe = normals * v_smith_ggx_correlated(n_dot_v, n_dot_l, s.alpha);
        // The solid angle of the part above the horizon, from its cosine-weighted one.
        float solid_angle = min(PI * form / max(dot(n, towards), 0.05), 2.0 * PI);
        float cone = acos(clamp(1.0 - solid_angle / (2.0 * PI), -1.0, 1.0));
        float share = ggx_share_within(tan(0.5 * min(cone, 0.5 * PI)), s.alpha);
        // Off the lobe's peak, the share shrinks as the normals there thin out (D against its peak).
        float off_peak = normals * PI * s.alpha * s.alpha;
        specular = min(f * lobe * PI * form, env_brdf_approx(s.f0, s.roughness, n_dot_v) * share * off_peak);
    }
    return (diffuse + specular) * light.color;
}

#endif
