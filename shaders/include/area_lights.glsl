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
const int AREA_MAX_CORNERS = AREA_DISK_SIDES + 1;   // clipping a convex polygon adds one corner

bool is_area_light(GpuLight light) {
    return light.kind == LIGHT_RECT || light.kind == LIGHT_DISK;
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

// The light's corners relative to `p`, in order around it.
int area_corners(GpuLight light, vec3 p, out vec3 corners[AREA_MAX_CORNERS]) {
    vec3 c = light.position - p;
    vec3 up = area_up(light);
    if (light.kind == LIGHT_RECT) {
        vec3 right = area_right(light);
        corners[0] = c - right - up;
        corners[1] = c + right - up;
        corners[2] = c + right + up;
        corners[3] = c - right + up;
        return 4;
    }
    // A regular polygon's area is n/2 · r² · sin(2π/n): scaled to πR².
    float scale = sqrt(PI / (0.5 * float(AREA_DISK_SIDES) * sin(2.0 * PI / float(AREA_DISK_SIDES))));
    vec3 right = normalize(area_right(light)) * light.size * scale;
    up *= scale;
    for (int i = 0; i < AREA_DISK_SIDES; ++i) {
        float a = 2.0 * PI * float(i) / float(AREA_DISK_SIDES);
        corners[i] = c + right * cos(a) + up * sin(a);
    }
    return AREA_DISK_SIDES;
}

// The cosine-weighted solid angle of the light's face seen from `p` over normal `n`, divided
// by π (the form factor: 1 for a light filling the hemisphere). The polygon is clipped to the
// horizon (Sutherland–Hodgman against n·x ≥ 0), and each edge adds its arc's projection on n.
// `towards` is the polygon's vector form factor's direction: where the light it sends comes
// from on average (the clipped part's, where the horizon cuts it).
float area_form_factor(GpuLight light, vec3 p, vec3 n, out vec3 towards) {
    vec3 corners[AREA_MAX_CORNERS];
    int count = area_corners(light, p, corners);
    vec3 clipped[AREA_MAX_CORNERS];
    int kept = 0;
    for (int i = 0; i < count; ++i) {
        vec3 a = corners[i], b = corners[(i + 1) % count];
        float da = dot(n, a), db = dot(n, b);
        if (da >= 0.0 && kept < AREA_MAX_CORNERS) clipped[kept++] = a;
        if ((da >= 0.0) != (db >= 0.0) && kept < AREA_MAX_CORNERS) clipped[kept++] = mix(a, b, da / (da - db));
    }
    vec3 sum = vec3(0.0);
    for (int i = 0; i < kept; ++i) {
        vec3 a = normalize(clipped[i]), b = normalize(clipped[(i + 1) % kept]);
        vec3 c = cross(a, b);
        float s = length(c);
        if (s > 1e-7) sum += c * (atan(s, dot(a, b)) / s);
    }
    // The winding as seen from p decides the sign, which the one-sided test has already settled.
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
