//! The one description of everything Rust and GLSL share: the `Gpu*` records, the push
//! constants and the constants shaders compare against.
//!
//! The `layout! { … }` invocation at the end of this file is the only place these are written.
//! It expands to
//! - the `#[repr(C)]`, `Pod` Rust structs and the `pub const`s (re-exported where the rest of the
//!   crate has always found them: `scene::Gpu*`, `gpu::pipeline::ScenePush`,
//!   `graph::targets::slots`, and `renderer::DebugView` takes its discriminants from `DEBUG_*`);
//! - compile-time assertions that each field's Rust type has the size and scalar type of its
//!   GLSL type, that each field's `offset_of!` is the offset GLSL gives it under the struct's
//!   layout rule (std430, scalar or push_constant), and that `size_of` is GLSL's array stride;
//! - [`ITEMS`], the same description as data, and [`glsl`], which writes it as a GLSL header.
//!
//! `render/build.rs` compiles this same file (`#[path = "src/layout.rs"] mod layout`), so the
//! assertions run there too; it writes [`glsl`]'s text to `$OUT_DIR/layout.glsl`, which the
//! shaders include (through `scene.glsl`), and compiles a probe shader with glslc to check that
//! glslang places every field at the offset [`ITEMS`] says. Rust, this table and the compiled
//! shaders therefore cannot disagree: any drift fails the build and names the field.
//! Buffer-reference blocks (`CameraRef { GpuCamera camera; }`) and helper functions stay in the
//! hand-written includes; only the shared data lives here.
//!
//! # Adding a field
//! 1. Write it in the struct below, in the order GLSL should see it, with a `///` doc (the doc
//!    becomes the field's comment in `layout.glsl`): `/// Metres.` then `pub radius: f32,`.
//!    Rust types and the GLSL types they become: `f32` float, `u32` uint, `u64` uint64_t,
//!    `Vec2`/`[f32; 2]` vec2, `Vec3`/`[f32; 3]` vec3, `Vec4`/`[f32; 4]` vec4, `Mat4` mat4,
//!    `[u32; N]` `uint name[N]` (add others by implementing [`GlslType`]). A push-constant field
//!    that GLSL sees as a typed buffer reference is `pub camera: u64 as CameraRef,` after a
//!    `buffer_reference CameraRef;` line.
//! 2. Keep the size a multiple of the struct's alignment (16 for std430 structs with a vec3,
//!    vec4 or mat4): take the bytes from the `pad` field or add one. If the field does not land
//!    where GLSL puts it, the build fails with "`Struct.field`: Rust offset is not the GLSL
//!    offset"; move it or pad before it.
//! 3. Use it by the same name in the shaders, and set it where Rust builds the record (struct
//!    literals without `..Zeroable::zeroed()` must name it). Nothing else to edit.
//!
//! # Adding a constant
//! Write `/// What it means.` then `pub const NAME: u32 = 7;` among the constants at the top of
//! the invocation (only `u32` constants are supported). It is `NAME` in Rust (re-export it from
//! the module where Rust code looks for it, as `scene` does) and `const uint NAME = 7u;` in
//! GLSL, where it replaces any hand-written copy.
//!
//! # Adding a struct
//! Write it like the others, where GLSL should declare it: docs, `#[layout(std430)]` (or
//! `#[layout(scalar)]` for a struct only read from scalar blocks), an optional
//! `#[derive(Default)]`, then `pub struct GpuName { … }`. Re-export it where Rust code expects
//! it; its methods and trait impls can live anywhere in the crate. build.rs checks it against
//! glslang without further ado. Declare the buffer-reference block that reaches it in the
//! hand-written include. Structs inside structs are not supported.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec2, Vec3, Vec4};

/// How GLSL lays out a struct (the block layout it is used in).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Rule {
    /// `std430` storage and buffer-reference blocks: vec3, vec4 and mat4 align to 16 bytes,
    /// vec2 and uint64_t to 8, scalars and arrays of scalars to 4.
    Std430,
    /// `scalar` blocks (`GL_EXT_scalar_block_layout`): everything aligns to its component.
    Scalar,
    /// The `layout(push_constant)` block (std430 rules).
    PushConstant,
}

/// The component type of a GLSL type; a field's Rust type and GLSL type must agree on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Scalar {
    /// 32-bit float.
    F32,
    /// 32-bit unsigned integer.
    U32,
    /// 64-bit unsigned integer (or a buffer device address).
    U64,
}

/// A type a field can have, with its GLSL name and layout. Implemented for the Rust field types
/// (each names its natural GLSL type) and for buffer-reference names (`buffer_reference X;`).
pub trait GlslType {
    /// GLSL type name; for arrays, the element type.
    const NAME: &'static str;
    /// Element count of an array (`uint pad[2]`), 0 for a non-array.
    const ARRAY: usize;
    /// Component type.
    const SCALAR: Scalar;
    /// Size in bytes (the same under every [`Rule`]).
    const SIZE: usize;
    /// Alignment under std430.
    const ALIGN_STD430: usize;
    /// Alignment under the scalar layout.
    const ALIGN_SCALAR: usize;
}

macro_rules! glsl_types {
    ($($rust:ty => $name:literal, $scalar:ident, $std430:literal, $scalar_align:literal;)*) => {$(
        impl GlslType for $rust {
            const NAME: &'static str = $name;
            const ARRAY: usize = 0;
            const SCALAR: Scalar = Scalar::$scalar;
            const SIZE: usize = size_of::<$rust>();
            const ALIGN_STD430: usize = $std430;
            const ALIGN_SCALAR: usize = $scalar_align;
        }
    )*};
}

glsl_types! {
    f32 => "float", F32, 4, 4;
    u32 => "uint", U32, 4, 4;
    u64 => "uint64_t", U64, 8, 8;
    Vec2 => "vec2", F32, 8, 4;
    [f32; 2] => "vec2", F32, 8, 4;
    Vec3 => "vec3", F32, 16, 4;
    [f32; 3] => "vec3", F32, 16, 4;
    Vec4 => "vec4", F32, 16, 4;
    [f32; 4] => "vec4", F32, 16, 4;
    Mat4 => "mat4", F32, 16, 4;
}

impl<const N: usize> GlslType for [u32; N] {
    const NAME: &'static str = "uint";
    const ARRAY: usize = N;
    const SCALAR: Scalar = Scalar::U32;
    const SIZE: usize = 4 * N;
    const ALIGN_STD430: usize = 4;
    const ALIGN_SCALAR: usize = 4;
}

impl<const N: usize> GlslType for [Vec4; N] {
    const NAME: &'static str = "vec4";
    const ARRAY: usize = N;
    const SCALAR: Scalar = Scalar::F32;
    const SIZE: usize = 16 * N;
    const ALIGN_STD430: usize = 16;
    const ALIGN_SCALAR: usize = 4;
}

/// One field of a [`Struct`] as GLSL sees it.
#[derive(Clone, Copy, Debug)]
pub struct Field {
    /// Name (the same in Rust and GLSL).
    pub name: &'static str,
    /// GLSL type name (the element type for arrays).
    pub glsl: &'static str,
    /// Array length, 0 for a non-array.
    pub array: usize,
    /// Size in bytes.
    pub size: usize,
    /// Alignment under the struct's rule.
    pub align: usize,
    /// Offset under the struct's rule (what `offset_of!` must equal).
    pub offset: usize,
    /// Doc comment lines.
    pub doc: &'static [&'static str],
}

/// A struct or the push-constant block as GLSL sees it.
#[derive(Clone, Copy, Debug)]
pub struct Struct {
    /// Name (the same in Rust and GLSL).
    pub name: &'static str,
    /// Layout rule.
    pub rule: Rule,
    /// Instance name of the push-constant block (`scene`); empty for other structs.
    pub instance: &'static str,
    /// Fields, in order, with their offsets.
    pub fields: &'static [Field],
    /// Size in bytes, a multiple of the alignment (the std430 array stride; `size_of` must equal it).
    pub size: usize,
    /// Doc comment lines.
    pub doc: &'static [&'static str],
}

/// One entry of the description.
#[derive(Clone, Copy, Debug)]
pub enum Item {
    /// `const uint NAME = value;`
    Const {
        /// Name.
        name: &'static str,
        /// Value.
        value: u32,
        /// Doc comment lines.
        doc: &'static [&'static str],
    },
    /// A forward declaration `layout(buffer_reference) buffer NAME;` (the block is hand-written).
    BufferReference {
        /// Name.
        name: &'static str,
        /// Doc comment lines.
        doc: &'static [&'static str],
    },
    /// A struct or the push-constant block.
    Struct(&'static Struct),
}

const fn align_up(x: usize, align: usize) -> usize {
    x.div_ceil(align) * align
}

#[doc(hidden)]
pub const fn rule_align<T: GlslType>(rule: Rule) -> usize {
    match rule {
        Rule::Scalar => T::ALIGN_SCALAR,
        Rule::Std430 | Rule::PushConstant => T::ALIGN_STD430,
    }
}

#[doc(hidden)]
/// Places `fields` one after another, each at the next multiple of its alignment.
pub const fn place<const N: usize>(mut fields: [Field; N]) -> [Field; N] {
    let mut end = 0;
    let mut i = 0;
    while i < N {
        fields[i].offset = align_up(end, fields[i].align);
        end = fields[i].offset + fields[i].size;
        i += 1;
    }
    fields
}

#[doc(hidden)]
/// The size of a struct of `fields` (placed): the end of the last field, rounded up to the
/// largest alignment.
pub const fn struct_size(fields: &[Field]) -> usize {
    let (mut end, mut align, mut i) = (0, 1, 0);
    while i < fields.len() {
        end = fields[i].offset + fields[i].size;
        if fields[i].align > align {
            align = fields[i].align;
        }
        i += 1;
    }
    align_up(end, align)
}

macro_rules! rule {
    (std430) => {
        Rule::Std430
    };
    (scalar) => {
        Rule::Scalar
    };
    (push_constant) => {
        Rule::PushConstant
    };
}

macro_rules! glsl_of {
    ($rust:ty) => {
        $rust
    };
    ($rust:ty as $glsl:ty) => {
        $glsl
    };
}

/// Expands the description; see the module doc.
macro_rules! layout {
    (@items [$($item:tt)*]) => {
        /// The whole description in order: what [`glsl`] writes and `build.rs` checks.
        pub const ITEMS: &[Item] = &[$($item)*];
    };

    (@items [$($item:tt)*]
        $(#[doc = $doc:literal])*
        pub const $name:ident: u32 = $value:expr;
        $($rest:tt)*
    ) => {
        $(#[doc = $doc])*
        pub const $name: u32 = $value;
        layout!(@items [$($item)* Item::Const { name: stringify!($name), value: $name, doc: &[$($doc),*] },] $($rest)*);
    };

    (@items [$($item:tt)*]
        $(#[doc = $doc:literal])*
        buffer_reference $name:ident;
        $($rest:tt)*
    ) => {
        $(#[doc = $doc])*
        ///
        /// A GLSL buffer-reference type (its block is declared in the hand-written includes);
        /// in Rust only a name for the layout description.
        pub struct $name;
        impl GlslType for $name {
            const NAME: &'static str = stringify!($name);
            const ARRAY: usize = 0;
            const SCALAR: Scalar = Scalar::U64;
            const SIZE: usize = 8;
            const ALIGN_STD430: usize = 8;
            const ALIGN_SCALAR: usize = 8;
        }
        layout!(@items [$($item)* Item::BufferReference { name: stringify!($name), doc: &[$($doc),*] },] $($rest)*);
    };

    (@items [$($item:tt)*]
        $(#[doc = $doc:literal])*
        #[layout($rule:ident $(, instance = $instance:ident)?)]
        $(#[derive($($derive:ident),*)])?
        pub struct $name:ident {
            $(
                $(#[doc = $field_doc:literal])*
                pub $field:ident: $rust:ty $(as $glsl:ty)?
            ),* $(,)?
        }
        $($rest:tt)*
    ) => {
        $(#[doc = $doc])*
        #[repr(C)]
        #[derive(Clone, Copy, Debug, PartialEq, Pod, Zeroable $($(, $derive)*)?)]
        pub struct $name {
            $(
                $(#[doc = $field_doc])*
                pub $field: $rust,
            )*
        }

        impl $name {
            /// This struct as GLSL sees it.
            pub const LAYOUT: Struct = {
                const FIELDS: &[Field] = &place([$(Field {
                    name: stringify!($field),
                    glsl: <glsl_of!($rust $(as $glsl)?) as GlslType>::NAME,
                    array: <glsl_of!($rust $(as $glsl)?) as GlslType>::ARRAY,
                    size: <glsl_of!($rust $(as $glsl)?) as GlslType>::SIZE,
                    align: rule_align::<glsl_of!($rust $(as $glsl)?)>(rule!($rule)),
                    offset: 0,
                    doc: &[$($field_doc),*],
                }),*]);
                Struct {
                    name: stringify!($name),
                    rule: rule!($rule),
                    instance: concat!("" $(, stringify!($instance))?),
                    fields: FIELDS,
                    size: struct_size(FIELDS),
                    doc: &[$($doc),*],
                }
            };
        }

        #[allow(unused_assignments)]
        const _: () = {
            let fields = $name::LAYOUT.fields;
            let mut i = 0;
            $(
                assert!(
                    size_of::<$rust>() == <glsl_of!($rust $(as $glsl)?) as GlslType>::SIZE
                        && <$rust as GlslType>::SCALAR as u8 == <glsl_of!($rust $(as $glsl)?) as GlslType>::SCALAR as u8,
                    concat!("`", stringify!($name), ".", stringify!($field), "`: the Rust type does not match the GLSL type")
                );
                assert!(
                    core::mem::offset_of!($name, $field) == fields[i].offset,
                    concat!("`", stringify!($name), ".", stringify!($field), "`: Rust offset is not the GLSL offset (reorder or pad)")
                );
                i += 1;
            )*
            assert!(
                size_of::<$name>() == $name::LAYOUT.size,
                concat!("`", stringify!($name), "`: Rust size is not the GLSL size (pad the end)")
            );
        };

        layout!(@items [$($item)* Item::Struct(&$name::LAYOUT),] $($rest)*);
    };

    (@items [$($item:tt)*] $next:tt $($rest:tt)*) => {
        compile_error!(concat!("layout!: cannot read the item at `", stringify!($next), "` (see the module doc for the forms)"));
    };

    ($($description:tt)*) => {
        layout!(@items [] $($description)*);
    };
}

/// The GLSL header `build.rs` writes to `$OUT_DIR/layout.glsl`: every item of [`ITEMS`] in
/// order, docs as comments, fields annotated with their offsets. The same description always
/// gives the same bytes.
pub fn glsl() -> String {
    fn doc(lines: &[&str]) -> String {
        lines.iter().map(|l| l.trim()).filter(|l| !l.is_empty()).collect::<Vec<_>>().join(" ")
    }
    /// Lines of `code // comment`, comments aligned.
    fn aligned(out: &mut String, lines: &[(String, String)]) {
        let width = lines.iter().map(|(code, _)| code.chars().count()).max().unwrap_or(0);
        for (code, comment) in lines {
            if comment.is_empty() {
                out.push_str(code);
            } else {
                out.push_str(&format!("{code:<width$}  // {comment}"));
            }
            out.push('\n');
        }
    }

    let mut out = String::from(
        "// Generated by render/build.rs from render/src/layout.rs: do not edit. Edit layout.rs\n\
         // (its module doc says how); Rust and the shaders both follow it.\n\
         #ifndef LAYOUT_GLSL\n\
         #define LAYOUT_GLSL\n\
         \n\
         #extension GL_EXT_buffer_reference : require\n\
         #extension GL_EXT_shader_explicit_arithmetic_types_int64 : require\n",
    );
    let mut items = ITEMS.iter().peekable();
    while let Some(item) = items.next() {
        out.push('\n');
        let line = |item: &Item| match *item {
            Item::Const { name, value, doc: d } => (format!("const uint {name} = {value}u;"), doc(d)),
            Item::BufferReference { name, doc: d } => (format!("layout(buffer_reference) buffer {name};"), doc(d)),
            Item::Struct(_) => unreachable!(),
        };
        let s = match item {
            Item::Struct(s) => s,
            _ => {
                // A run of constants (or of forward declarations) is one aligned block.
                let mut run = vec![line(item)];
                while let Some(next) = items.next_if(|n| std::mem::discriminant(*n) == std::mem::discriminant(item)) {
                    run.push(line(next));
                }
                aligned(&mut out, &run);
                continue;
            }
        };
        let rule = match s.rule {
            Rule::Std430 => "std430",
            Rule::Scalar => "scalar layout: use only in scalar blocks",
            Rule::PushConstant => "push constants",
        };
        out.push_str(&format!("// {} ({rule}, {} bytes)\n", doc(s.doc), s.size));
        out.push_str(&match s.rule {
            // Shaders with push constants of their own (the culling passes) define NO_SCENE_PUSH.
            Rule::PushConstant => format!("#ifndef NO_SCENE_PUSH\nlayout(push_constant) uniform {} {{\n", s.name),
            _ => format!("struct {} {{\n", s.name),
        });
        let fields: Vec<_> = s
            .fields
            .iter()
            .map(|f| {
                let array = if f.array > 0 { format!("[{}]", f.array) } else { String::new() };
                (format!("    {} {}{array};", f.glsl, f.name), format!("{}: {}", f.offset, doc(f.doc)))
            })
            .collect();
        aligned(&mut out, &fields);
        out.push_str(&match s.rule {
            Rule::PushConstant => format!("}} {};\n#endif\n", s.instance),
            _ => "};\n".to_string(),
        });
    }
    out.push_str("\n#endif\n");
    out
}

layout! {
    /// Material flag: alpha-tested against `alpha_cutoff`.
    pub const MATERIAL_ALPHA_MASK: u32 = 1;
    /// Material flag: both faces are drawn and lit.
    pub const MATERIAL_DOUBLE_SIDED: u32 = 2;
    /// Blended surfaces: the largest refraction displacement the G-buffer holds, in millimetres
    /// (`GpuMaterial::refraction` is stored over 8 bits of this range, 1 mm a step).
    pub const REFRACTION_MAX_MM: u32 = 250;
    /// Material flag: blended transparency (glTF `BLEND`): `base_color.a` (times the texture's
    /// alpha) is the opacity. Drawn by the transparency passes only; shadow rays that cross such
    /// a surface carry on, filtered by its colour × (1 − opacity) (`COLOURED_SHADOWS`).
    pub const MATERIAL_BLEND: u32 = 4;

    /// Bindless slot of the built-in 1×1 white texture (a material without a texture samples this).
    pub const TEXTURE_WHITE: u32 = 0;
    /// Bindless slot of the built-in flat normal map.
    pub const TEXTURE_FLAT_NORMAL: u32 = 1;
    /// Bindless slot of the built-in table of the GGX lobe's linearly transformed cosines and
    /// magnitudes that area lights shade their specular term with (`crate::lights::ltc`, RGBA32F,
    /// `2 × LTC_SIZE` by `LTC_SIZE` texels, fetched with `texelFetch`).
    pub const TEXTURE_LTC: u32 = 2;
    /// Descriptor binding (set 0) of the HDR target (`hdr_target`; tone mapping samples it).
    /// Each render target has a binding of its own, not a slot in the bindless array: a shader
    /// then statically uses exactly the targets its pass declares it samples, and the
    /// synchronization validation layer (which treats every element of a used array as read)
    /// sees no false read of a target another attachment is writing.
    pub const BINDING_HDR: u32 = 1;
    /// Binding of the depth target (`depth_target`; full-screen passes reconstruct positions).
    pub const BINDING_DEPTH: u32 = 2;
    /// Binding of the G-buffer albedo (`gbuffer_albedo`).
    pub const BINDING_GBUFFER_ALBEDO: u32 = 3;
    /// Binding of the G-buffer normal (`gbuffer_normal`).
    pub const BINDING_GBUFFER_NORMAL: u32 = 4;
    /// Binding of the G-buffer roughness/metallic (`gbuffer_material`).
    pub const BINDING_GBUFFER_MATERIAL: u32 = 5;
    /// Binding of the G-buffer receiver layers (`gbuffer_layers`, unsigned integer).
    pub const BINDING_GBUFFER_LAYERS: u32 = 6;
    /// Binding of the visibility buffer's ids (`visibility_ids`, unsigned integer).
    pub const BINDING_VISIBILITY: u32 = 7;
    /// Binding of the transparent depth (`transparent_depth`, reverse-Z D32): the nearest
    /// transparent surface per pixel, written by the transparency depth pass; light culling
    /// widens each tile's depth range to hold it, so the lists light the glass too.
    pub const BINDING_TRANSPARENT_DEPTH: u32 = 8;
    /// Binding of the lit image the transparency compositions read (`transparency_source`,
    /// RGBA16F: a copy of the HDR target after lighting; with depth peeling, after lighting the
    /// opaque layer).
    pub const BINDING_TRANSPARENCY_SOURCE: u32 = 9;
    /// Binding of the shadow-map atlas's depth (`shadow_map_depth`, reverse-Z D32): one tile
    /// per shadow view (`shaders/include/shadow_maps.glsl`).
    pub const BINDING_SHADOW_MAP_DEPTH: u32 = 10;
    /// Binding of the shadow-map atlas's filter (`shadow_map_filter`, RGBA8): the colour and
    /// opacity of the glass nearest the light on odd rows, (1, 1, 1, 1) where an opaque surface
    /// is (seed 002 §3.2.1, Table 3.3).
    pub const BINDING_SHADOW_MAP_FILTER: u32 = 11;
    /// Binding of the opaque layer's depth under depth peeling (`background_depth`, reverse-Z
    /// R32F: a copy of the depth target after the opaque G-buffer).
    pub const BINDING_BACKGROUND_DEPTH: u32 = 12;
    /// Binding of the anti-aliased display colour (`antialiased`, RGBA16F: tone-mapped linear
    /// colour), which the FXAA pass writes and the display pass copies out.
    pub const BINDING_ANTIALIASED: u32 = 13;
    /// Binding of the decal buffer's albedo (`decal_albedo`, storage image RGBA16F): the
    /// premultiplied decal albedo (rgb) and the weight left to the surface's own (a). The decal
    /// pass writes the decal buffer; shading applies `value = decal + value × remaining`.
    pub const BINDING_DECAL_ALBEDO: u32 = 14;
    /// Binding of the decal buffer's normal (`decal_normal`, RGBA16F): decal normal (xyz) and
    /// the weight left to the surface normal (w).
    pub const BINDING_DECAL_NORMAL: u32 = 15;
    /// Binding of the decal buffer's roughness/metallic (`decal_spec`, RGBA16F): decal roughness
    /// and metallic (xy), the weights left to the surface's (zw).
    pub const BINDING_DECAL_SPEC: u32 = 16;
    /// Binding of the decal buffer's count of decals tested per pixel (`decal_tested`, R32UI):
    /// the debug views read it, and the shading reads the other images only where it is not 0
    /// (a pixel where no decal was tested gets its count alone).
    pub const BINDING_DECAL_TESTED: u32 = 17;
    /// Number of bindless slots the renderer reserves for itself (built-ins and render targets;
    /// scene textures start here).
    pub const RESERVED_TEXTURES: u32 = 16;

    /// Light kind (`GpuLight::kind`, `LightKind`): an empty slot.
    pub const LIGHT_NONE: u32 = 0;
    /// Light kind: omnidirectional point light.
    pub const LIGHT_POINT: u32 = 1;
    /// Light kind: cone-shaped spot light.
    pub const LIGHT_SPOT: u32 = 2;
    /// Light kind: infinitely distant light.
    pub const LIGHT_DIRECTIONAL: u32 = 3;
    /// Light kind: one-sided rectangle (`GpuLight::direction` its facing, the spot fields its
    /// half-width vector, `size` its half height).
    pub const LIGHT_RECT: u32 = 4;
    /// Light kind: one-sided disk (`GpuLight::direction` its facing, the spot fields a unit
    /// vector in its plane, `size` its radius).
    pub const LIGHT_DISK: u32 = 5;
    /// Specialization constant id of `AREA_LIGHTS` (`area_lights.glsl`): whether a pipeline
    /// keeps the area lights' code (`crate::gpu::pipeline::Specialization`). Without it, a rect
    /// or disk light would shade as a point light, so shading passes drop it only while the
    /// scene has none (its registers slowed the many-lights scene's shading by a third on the
    /// lent H200). Every pipeline is made with this id's entry (true unless specialized): a
    /// shader must not use id 0 for anything else.
    pub const SPEC_AREA_LIGHTS: u32 = 0;
    /// Specialization constant id of `STAGED_LIGHTS` (`shading.glsl`): whether a compute shading
    /// pass stages its workgroup's unshadowed light lists in shared memory
    /// (`crate::gpu::pipeline::Specialization`). Shading passes use it only in frames where
    /// pixels sample their shadows: its registers slowed the lists that are walked a thread at a
    /// time. Every pipeline is made with this id's entry: a shader must not use id 1 for
    /// anything else.
    pub const SPEC_STAGED_LIGHTS: u32 = 1;
    /// The lights a staging workgroup reads at once (`STAGED_LIGHTS`, `shading.glsl`: one a
    /// thread of its 8×8); a list no longer than this is not staged.
    pub const STAGED_LIGHTS_CHUNK: u32 = 64;

    /// Decal material flag: blends albedo.
    pub const DECAL_ALBEDO: u32 = 1;
    /// Decal material flag: blends normals.
    pub const DECAL_NORMAL: u32 = 2;
    /// Decal material flag: blends roughness.
    pub const DECAL_ROUGHNESS: u32 = 4;
    /// Decal material flag: blends metallic.
    pub const DECAL_METALLIC: u32 = 8;
    /// Decal material flag: emits light (added to the surface's emission).
    pub const DECAL_EMISSIVE: u32 = 16;
    /// Number of decal blending channels (a `GpuDecal`'s channel is below this).
    pub const DECAL_CHANNELS: u32 = 4;
    /// `GpuDecal::material_channel`: the channel sits above this many bits of material slot.
    pub const DECAL_CHANNEL_SHIFT: u32 = 30;
    /// `GpuAabb::slot` of a box that belongs to no decal (the padding of a BLAS build).
    pub const NO_DECAL: u32 = 0xFFFF_FFFF;
    /// Receiver bit of decals on a skin (`render/src/skinning`): they apply only where a skinned
    /// surface is looked up at its rest-pose position, and world decals only elsewhere. Reserved:
    /// decal and instance layers are the 31 bits below it.
    pub const DECAL_ON_SKIN: u32 = 0x8000_0000;
    /// The receiver layers of an instance that names none. Where every instance has them and no
    /// decal is on a skin, a decal pass needs nothing of an instance (`DECAL_SURFACE_DEPTH` in
    /// `shaders/include/decal_surface.glsl`).
    pub const DECAL_DEFAULT_LAYERS: u32 = 1;
    /// Clustered decals: the side of a cluster's screen tile, in pixels.
    pub const DECAL_CLUSTER_TILE: u32 = 32;
    /// Clustered decals: depth slices of each screen tile, exponential in view distance over the
    /// distances the tile's shaded pixels reach (none thinner than 2 % of its distance).
    pub const DECAL_CLUSTER_SLICES: u32 = 16;
    /// Clustered decals: workgroups in a row of the binning dispatch (8 boxes a workgroup).
    pub const DECAL_BIN_ROW: u32 = 4096;
    /// Clustered decals: 32-bit words of statistics at the start of the cluster buffer (see
    /// `shaders/include/clusters.glsl`).
    pub const DECAL_CLUSTER_HEADER: u32 = 16;
    /// The ray-tracing-pipeline decal pass's per-pixel lists: 32-bit words of header at the
    /// start of the list buffer (`shaders/include/decal_lists.glsl`).
    pub const DECAL_LIST_HEADER: u32 = 8;

    /// Light assignment (`GpuLighting::mode`): every pixel loops over every light.
    pub const LIGHTS_ALL: u32 = 0;
    /// Light assignment: tiled light culling's per-tile lists (seed 001 §4.2).
    pub const LIGHTS_TILED: u32 = 1;
    /// Light assignment: lights found by a zero-length ray against their boxes (seed 000 §5.2.5).
    pub const LIGHTS_RAY_QUERY: u32 = 2;
    /// `GpuLighting::flags`: light culling also tests point lights against the tile's AABB.
    pub const LIGHT_CULL_AABB: u32 = 1;
    /// `GpuLighting::flags`: no shadow ray towards a light the reconstructed normal faces away
    /// from (seed 001 §4.3).
    pub const SHADOW_RAY_CULLING: u32 = 2;
    /// `GpuLighting::flags`: normals from depth by the improved 5-tap method (seed 001 §4.3.1)
    /// instead of the naive 3-tap one.
    pub const SHADOW_NORMALS_IMPROVED: u32 = 4;
    /// `GpuLighting::flags`: the shadow pass traced this frame (shading reads its bits).
    pub const SHADOWS_TRACED: u32 = 8;
    /// `GpuLighting::flags`: the shadow pass also writes the shadow debug image.
    pub const SHADOW_DEBUG: u32 = 16;
    /// `GpuLighting::flags`: the deferred G-buffer interlaces transparency (odd rows hold the
    /// nearest blended surface where there is one), so passes that rebuild surfaces from depth
    /// step two rows to stay on one surface (`row_step` in `shaders/include/depth.glsl`).
    pub const INTERLACED: u32 = 32;
    /// `GpuLighting::flags`: the interlaced composition refracts (`FrameSettings::refraction`).
    pub const REFRACTION: u32 = 64;
    /// `GpuLighting::flags`: blended surfaces filter the light that crosses them (coloured
    /// shadows, `LightSettings::coloured_shadows`); without it they block it like opaque ones.
    pub const COLOURED_SHADOWS: u32 = 128;
    /// `GpuLighting::flags`: the shadow pass also ran over the transparent depth (its glass
    /// layer, `GLASS_LAYER` in `shaders/include/shadow_pass.glsl`), so the forward transparency
    /// pass shades the nearest blended surface with its own shadows.
    pub const GLASS_SHADOWS: u32 = 256;
    /// `GpuLighting::flags`: the ambient occlusion pass ran (`crate::occlusion`):
    /// shading multiplies ambient light by its image.
    pub const AMBIENT_OCCLUSION: u32 = 512;
    /// `GpuLighting::flags`: light culling also tests lights against each tile's depth mask (32
    /// slices of its depth range, a bit for each slice a pixel lies in: Harada 2012's 2.5D culling).
    pub const LIGHT_CULL_DEPTH_MASK: u32 = 1024;
    /// Coloured shadows: per pixel, how many lights keep the colour their light crossed glass
    /// with (`GpuLighting::shadow_tints`); a pixel's further tinted lights are lit or shadowed
    /// by the tint's luminance.
    pub const SHADOW_TINT_SLOTS: u32 = 2;
    /// Light tiles: 32-bit words of statistics at the start of the light tile buffer (see
    /// `shaders/include/light_tiles.glsl`).
    pub const LIGHT_TILE_HEADER: u32 = 16;
    /// Light tiles: a tile's count with this bit set overflowed the list (its pixels loop over
    /// every light, unshadowed, until the buffer grows).
    pub const LIGHT_TILE_OVERFLOW: u32 = 0x8000_0000;
    /// Light tiles: lights whose culling results fit in the culling pass's shared memory (more
    /// are tested twice).
    pub const LIGHT_CULL_SHARED_LIGHTS: u32 = 32768;
    /// Binding of the shadow debug image (`shadow_debug`, storage RGBA16F): the reconstructed
    /// normal × 0.5 + 0.5 (rgb) and the shadow rays traced (a).
    pub const BINDING_SHADOW_DEBUG: u32 = 18;
    /// Binding of the opaque layer's depth under depth peeling as a storage image
    /// (`background_depth_out`, R32F), which the copy writes.
    pub const BINDING_BACKGROUND_DEPTH_STORAGE: u32 = 19;
    /// Binding of the HDR target as a storage image (`hdr_image`, RGBA16F), for the lighting
    /// passes that run in compute.
    pub const BINDING_HDR_STORAGE: u32 = 20;
    /// Binding of the anti-aliased display colour as a storage image (`antialiased_out`), which
    /// the FXAA pass writes.
    pub const BINDING_ANTIALIASED_STORAGE: u32 = 21;
    /// Binding of the reflected radiance (`reflection_image`, storage RGBA16F): what each
    /// traced reflection ray brought back (rgb) and the view depth of the pixel that traced it
    /// (a; 0 where none did), at full or half resolution (`REFLECT_HALF_RES`).
    pub const BINDING_REFLECTION: u32 = 22;
    /// Binding of the reflection weights (`reflection_weight`, storage RGBA16F): per pixel the
    /// reflected radiance's weight (rgb: the pre-integrated specular reflectance × occlusion ×
    /// the fade towards the roughness cut-off) and the surface's roughness (a; negative where
    /// nothing reflects).
    pub const BINDING_REFLECTION_WEIGHT: u32 = 23;
    /// Binding of what each reflection ray found (`rays_out`, storage R32UI, one word per cell:
    /// a pixel, or a 2×2 block at half resolution; `pack_cell` in
    /// `shaders/include/reflections.glsl`), which the resolve counts and upsamples by.
    pub const BINDING_REFLECTION_RAYS: u32 = 24;
    /// Binding of the environment's prefiltered specular cube (`environment_specular`,
    /// RGBA16F, sampled in the GENERAL layout its filtering passes write it in): level `i` holds
    /// the radiance reflected by a surface of roughness `i / (levels − 1)` (`crate::environment`).
    pub const BINDING_ENVIRONMENT: u32 = 25;
    /// Binding of the environment's radiance cube (`environment_source`, RGBA16F, box-filtered
    /// mips): the sky is drawn from it, and the prefiltering samples it.
    pub const BINDING_ENVIRONMENT_SOURCE: u32 = 26;
    /// Binding of the split-sum BRDF table (`brdf_lut`, RG16F): the GGX lobe's scale and bias
    /// of F0 (x: n·v, y: perceptual roughness).
    pub const BINDING_BRDF_LUT: u32 = 27;
    /// Binding of the environment cubes' levels as storage images (`environment_levels`, an
    /// array of `ENVIRONMENT_LEVEL_VIEWS` 6-layer views): the radiance cube's levels first, then
    /// the specular cube's from `ENVIRONMENT_SPECULAR_VIEWS`.
    pub const BINDING_ENVIRONMENT_LEVELS: u32 = 28;
    /// Binding of the BRDF table as a storage image (`brdf_lut_out`), which its pass writes once.
    pub const BINDING_BRDF_LUT_STORAGE: u32 = 29;
    /// Binding of the decal buffer's emission (`decal_emissive`, storage RGBA16F): the radiance
    /// the pixel's emissive decals add (rgb; a unused). Emission adds light, so it has no weight
    /// left to the surface's own (`shaders/include/blend.glsl`).
    pub const BINDING_DECAL_EMISSIVE: u32 = 30;
    /// Binding of the ambient occlusion the tracing pass leaves (`occlusion_raw`, storage R32F:
    /// the share of short rays that escaped, noisy), which the denoiser reads
    /// (`crate::occlusion`).
    pub const BINDING_OCCLUSION_RAW: u32 = 31;
    /// Binding of the denoised ambient occlusion (`occlusion_image`, storage R32F) that shading
    /// multiplies the environment's and the ambient colour's light by.
    pub const BINDING_OCCLUSION: u32 = 32;
    /// Binding of the motion vectors (`motion_image`, storage RGBA16F, `crate::motion`): xy the
    /// screen-space motion since the previous frame in UV units (this frame's position less the
    /// previous one, both unjittered), z the surface's view depth in the previous frame, w its
    /// view depth in this one (what temporal anti-aliasing's disocclusion test compares).
    pub const BINDING_MOTION: u32 = 33;
    /// Binding of temporal anti-aliasing's first history image, sampled (`taa_history_a`,
    /// RGBA16F: the resolved colour, and in a the view depth it was resolved at).
    pub const BINDING_TAA_HISTORY_A: u32 = 34;
    /// Binding of the second history image, sampled (`taa_history_b`): the two alternate.
    pub const BINDING_TAA_HISTORY_B: u32 = 35;
    /// Binding of the first history image as a storage image (`taa_history_a_out`).
    pub const BINDING_TAA_HISTORY_A_STORAGE: u32 = 36;
    /// Binding of the second history image as a storage image (`taa_history_b_out`).
    pub const BINDING_TAA_HISTORY_B_STORAGE: u32 = 37;
    /// Binding of SMAA's edges (`smaa_edges`, storage RGBA8, `crate::smaa`): x an edge on the
    /// pixel's left side, y on its top side.
    pub const BINDING_SMAA_EDGES: u32 = 38;
    /// Binding of SMAA's blending weights (`smaa_weights`, storage RGBA8): how much of its top
    /// neighbour's colour the pixel takes (x) and of its own the top neighbour takes (y); z and w
    /// the same with its left neighbour.
    pub const BINDING_SMAA_WEIGHTS: u32 = 39;
    /// Binding of the reflections' resolved term (`reflection_added`, storage RGBA16F): what the
    /// reflection resolve would add to each pixel's radiance, kept apart under MSAA so that the
    /// shading pass adds it to each sample from the pixel of the sample's own surface
    /// (`crate::msaa`).
    pub const BINDING_REFLECTION_ADDED: u32 = 40;
    /// Binding of the sampled shadows (`shadow_samples`, storage RGBA16F,
    /// `crate::lights::sampling`): per pixel that sampled its lights, the light that got through
    /// along its one shadow ray (rgb: 1 unblocked, 0 blocked, a colour through glass) and log2
    /// of the estimate of its unshadowed light the ray's light was drawn from (a; exactly
    /// `SAMPLED_NONE` in `direct_sampling.glsl` where the pixel sampled nothing).
    pub const BINDING_SHADOW_SAMPLES: u32 = 41;
    /// Binding of the denoised shadow ratio (`shadow_ratio`, storage RGBA16F): the share of the
    /// unshadowed light that reaches each sampling pixel (rgb), which shading multiplies its
    /// lights' unshadowed sum by.
    pub const BINDING_SHADOW_RATIO: u32 = 42;
    /// Direct lighting: the most lights a sampling pixel draws from (its whole list up to this
    /// length; beyond, one from each of this many equal strata of it).
    pub const DIRECT_LIGHT_CANDIDATES: u32 = 64;
    /// Direct lighting: the most directional lights a sampling pixel traces apart
    /// (`GpuLighting::suns`).
    pub const DIRECT_LIGHT_SUNS: u32 = 4;
    /// Temporal anti-aliasing's push word (`ScenePush::texture_index`): its history is thrown
    /// away this frame (the first frame, a resize, a pipeline switch, a camera cut).
    pub const TAA_RESET: u32 = 1;
    /// Temporal anti-aliasing's push word: odd rows hold interlaced glass this frame, so motion
    /// and depth are read from the even row above (the surface behind the glass).
    pub const TAA_INTERLACED: u32 = 2;
    /// Temporal anti-aliasing's push word: the sharpening strength sits in the high 16 bits
    /// (unorm16) of the output pass's word.
    pub const TAA_SHARPEN_SHIFT: u32 = 16;
    /// Views in `BINDING_ENVIRONMENT_LEVELS` (16 radiance levels, then 16 specular ones).
    pub const ENVIRONMENT_LEVEL_VIEWS: u32 = 32;
    /// The first specular level's view in `BINDING_ENVIRONMENT_LEVELS`.
    pub const ENVIRONMENT_SPECULAR_VIEWS: u32 = 16;
    /// `GpuEnvironmentJob::mode`: a procedural sky lit by the scene's brightest directional light.
    pub const ENVIRONMENT_SKY: u32 = 1;
    /// `GpuEnvironmentJob::mode`: an equirectangular HDR map (`GpuEnvironmentJob::source`).
    pub const ENVIRONMENT_MAP: u32 = 2;
    /// `GpuEnvironmentJob::mode`: the same radiance in every direction (`GpuEnvironmentJob::color`).
    pub const ENVIRONMENT_UNIFORM: u32 = 3;
    /// `GpuEnvironmentJob::mode`: a cube map's six faces stacked in one image
    /// (`GpuEnvironmentJob::source`; `source_size` is a face's side and six times it).
    pub const ENVIRONMENT_CUBE_MAP: u32 = 4;
    /// `GpuLighting::environment_flags`: an environment lights the scene (else the flat ambient
    /// colour and the clear colour).
    pub const ENVIRONMENT_ON: u32 = 1;
    /// `GpuLighting::environment_flags`: the sky pass draws the sun's disc (the procedural sky,
    /// whose sun is the directional light and so is not in the cube).
    pub const ENVIRONMENT_SUN_DISC: u32 = 2;
    /// `GpuLighting::tonemapper`: Khronos PBR Neutral.
    pub const TONEMAP_PBR_NEUTRAL: u32 = 0;
    /// `GpuLighting::tonemapper`: ACES, Hill's fit.
    pub const TONEMAP_ACES_FITTED: u32 = 1;
    /// `GpuLighting::tonemapper`: AgX, Wrensch's minimal fit.
    pub const TONEMAP_AGX: u32 = 2;
    /// Most levels of the bloom pyramid (the first at half resolution).
    pub const BLOOM_MAX_LEVELS: u32 = 7;
    /// `GpuEmitter::contact`: a particle that touches a surface dies there.
    pub const PARTICLE_CONTACT_DIE: u32 = 0;
    /// `GpuEmitter::contact`: a particle that touches a surface bounces off it.
    pub const PARTICLE_CONTACT_BOUNCE: u32 = 1;
    /// `GpuEmitter::contact`: a particle that touches a surface stays where it touched.
    pub const PARTICLE_CONTACT_STICK: u32 = 2;
    /// `GpuEmitter::contact`: a particle passes through surfaces.
    pub const PARTICLE_CONTACT_NONE: u32 = 3;
    /// `GpuParticle::flags`: the particle has touched a surface and stays on it.
    pub const PARTICLE_STUCK: u32 = 1;
    /// `GpuParticle::flags`: the particle has touched a surface (it was counted as landed).
    pub const PARTICLE_LANDED: u32 = 2;
    /// Invocations of a particle workgroup (emission, simulation).
    pub const PARTICLE_GROUP: u32 = 64;
    /// Vertices a drawn particle's sprite takes (`particle.vert`): one triangle around its
    /// quad or round dot.
    pub const PARTICLE_SPRITE_VERTICES: u32 = 3;
    /// The bit of a decal slot that names a GPU-born decal (`crate::particles`): the rest is its
    /// place in the particles' decal ring, whose records and boxes the GPU writes.
    pub const GPU_DECAL: u32 = 0x4000_0000;
    /// Places of the particles' decal ring in one BLAS of its structure, for rings of up to 64
    /// times this (a ring with less room is one BLAS, a larger one has longer segments: shaders
    /// read `GpuLighting::decal_ring_segment`), so that a frame rebuilds only the stretches of
    /// the ring that filled (`crate::particles::ring_accel`).
    pub const DECAL_RING_SEGMENT: u32 = 256;
    /// `ScenePush::texture_index` of a deferred-decal draw of the particles' decal ring: this
    /// bit, and in the low four bits the `DECAL_*` attribute flags of the decals it draws.
    pub const DECAL_RING_DRAW: u32 = 0x100;
    /// Auto-exposure: bins of the luminance histogram (`GpuExposure`); bin 0 holds black and
    /// what is darker than 2^−`EXPOSURE_LOG2_OFFSET`, the others split the `EXPOSURE_LOG2_RANGE`
    /// stops above it.
    pub const EXPOSURE_BINS: u32 = 128;
    /// Auto-exposure: −log2 of the darkest luminance the histogram resolves (2^−12).
    pub const EXPOSURE_LOG2_OFFSET: u32 = 12;
    /// Auto-exposure: stops the histogram spans (2^−12 to 2^12).
    pub const EXPOSURE_LOG2_RANGE: u32 = 24;
    /// Side of the split-sum BRDF table in texels.
    pub const BRDF_LUT_SIZE: u32 = 64;
    /// Cells along each axis of the area lights' LTC table (`TEXTURE_LTC`): perceptual
    /// roughness and √(1 − n·v), each from 0 to 1.
    pub const LTC_SIZE: u32 = 32;
    /// `GpuLighting::reflection_flags`: the reflection pass runs this frame.
    pub const REFLECT_ON: u32 = 1;
    /// `GpuLighting::reflection_flags`: one ray per 2×2 pixels (a cell), upsampled by depth.
    pub const REFLECT_HALF_RES: u32 = 2;
    /// `GpuLighting::reflection_flags`: the hit points look for decals (off only to measure
    /// what they cost).
    pub const REFLECT_DECALS: u32 = 4;
    /// `GpuLighting::reflection_flags`: the rays are marched in screen space (no ray tracing).
    pub const REFLECT_SCREEN_SPACE: u32 = 8;
    /// Reflections: 32-bit words of statistics (`GpuLighting::reflection_stats`): pixels that
    /// reflect, rays traced, rays that hit geometry, decal candidates tested at hit points,
    /// decals applied there, light candidates found there, shadow rays not blocked.
    pub const REFLECTION_STATS: u32 = 8;
    /// Shadow maps: the first view of a light slot without a shadow map.
    pub const NO_SHADOW_MAP: u32 = 0xFFFF_FFFF;
    /// Shadow maps: 32-bit words before the slot table in the views buffer (the word offset
    /// of the views, their count, padding).
    pub const SHADOW_VIEWS_HEADER: u32 = 4;

    /// Debug view (`ScenePush::debug_view`, `DebugView`): the lit image.
    pub const DEBUG_LIT: u32 = 0;
    /// Debug view: decals tested per pixel, as a heat map.
    pub const DEBUG_DECAL_HEATMAP: u32 = 1;
    /// Debug view: albedo after decals (linear).
    pub const DEBUG_ALBEDO: u32 = 2;
    /// Debug view: world normal after decals, encoded n × 0.5 + 0.5.
    pub const DEBUG_NORMAL: u32 = 3;
    /// Debug view: roughness (R) and metallic (G) after decals.
    pub const DEBUG_ROUGHNESS_METALLIC: u32 = 4;
    /// Debug view: decals tested per pixel as a raw count in R (for tests).
    pub const DEBUG_DECAL_COUNT: u32 = 5;
    /// Debug view: lights in the pixel's list (its tile's, or every light) as a heat map.
    pub const DEBUG_LIGHT_HEATMAP: u32 = 6;
    /// Debug view: shadow rays traced at the pixel, as a heat map.
    pub const DEBUG_SHADOW_RAYS: u32 = 7;
    /// Debug view: the normal the shadow pass reconstructed from depth (left half) next to the
    /// shading normal (right half), encoded n × 0.5 + 0.5.
    pub const DEBUG_DEPTH_NORMALS: u32 = 8;
    /// Debug view: lights in the pixel's list as a raw count in R (for tests).
    pub const DEBUG_LIGHT_COUNT: u32 = 9;
    /// Debug view: the shadow pass's visibility of the first light as R (for tests).
    pub const DEBUG_SHADOW_FIRST: u32 = 10;
    /// Debug view: the reflection rays, as a heat map of their hit distance where a pixel
    /// traced one (white: missed, to the sky), the lit image dimmed where none was traced.
    pub const DEBUG_REFLECTIONS: u32 = 11;
    /// Debug view: the ambient occlusion shading multiplies ambient light by, as grey (white
    /// where it is off).
    pub const DEBUG_AMBIENT_OCCLUSION: u32 = 12;
    /// Debug view: decals whose box holds the pixel's surface point and whose fades leave
    /// something (at a skinned pixel, in both its views), as a raw count in R, counted by the
    /// ray-tracing-pipeline decal pass's count-only variant (no decal applied): the floor of
    /// that pass's enumeration, for benchmarks and tests.
    pub const DEBUG_DECAL_FLOOR: u32 = 13;
    /// Debug view: each surface in the colour of the level of detail its instance drew
    /// (`render/src/lod`): level 0 white, then blue, green, yellow and red as the levels coarsen;
    /// meshes without levels dark grey.
    pub const DEBUG_LOD: u32 = 14;

    /// `GpuSkinJob::levels`: the level of detail whose vertices the job skins.
    pub const SKIN_LEVEL_MASK: u32 = 255;
    /// `GpuSkinJob::levels`: where the level of the posed mesh's last skinning sits.
    pub const SKIN_PREVIOUS_SHIFT: u32 = 8;
    /// `GpuSkinJob::levels`: the posed mesh's first skinning.
    pub const SKIN_FIRST: u32 = 1 << 16;

    /// Culling record flag: the slot holds a live instance.
    pub const CULL_LIVE: u32 = 1;
    /// Culling record flag: alpha-tested (the masked batches).
    pub const CULL_MASKED: u32 = 2;
    /// Culling record flag: drawn without back-face culling (the double-sided batches).
    pub const CULL_DOUBLE_SIDED: u32 = 4;
    /// Culling record flag: blended; drawn by the transparency passes only, in their order.
    pub const CULL_TRANSPARENT: u32 = 8;
    /// Culling record: the finest level of detail the instance may be drawn at sits in the
    /// flags' bits from here (`CULL_LEVEL_MASK`): a posed mesh skinned only for its coarser
    /// levels this frame (`render/src/skinning`) holds no finer one.
    pub const CULL_LEVEL_SHIFT: u32 = 8;
    /// Culling record: the mask of the finest drawable level, after `CULL_LEVEL_SHIFT`.
    pub const CULL_LEVEL_MASK: u32 = 7;
    /// Draw batches of the opaque passes: opaque or masked × back-face culled or double-sided
    /// (`batch = 2 × masked + double_sided`).
    pub const CULL_BATCHES: u32 = 4;
    /// Words of the draw buffer's header: the per-batch counts of the two phases' lists
    /// (`2 × CULL_BATCHES`), then the statistics (`CULL_STAT_*`), then padding.
    pub const CULL_HEADER: u32 = 24;
    /// Header word: instances tested for the main view.
    pub const CULL_STAT_TESTED: u32 = 8;
    /// Header word: instances inside the main view's frustum.
    pub const CULL_STAT_FRUSTUM: u32 = 9;
    /// Header word: instances left after occlusion (drawn in either phase).
    pub const CULL_STAT_VISIBLE: u32 = 10;
    /// Header word: draws dropped because a batch's list was full (never expected).
    pub const CULL_STAT_DROPPED: u32 = 11;
    /// Header word: the blended order's length (the count of the glass draws).
    pub const CULL_ORDERED: u32 = 12;
    /// Header words: instances the main view drew at each level of detail (`LOD_LEVELS + 1`
    /// words, level 0 first).
    pub const CULL_STAT_LOD: u32 = 16;
    /// Header word: triangles the main view's lists draw (at their levels of detail).
    pub const CULL_STAT_TRIANGLES: u32 = 21;
    /// Levels of detail a mesh may have after its own triangle list (`render/src/lod`).
    pub const LOD_LEVELS: u32 = 4;
    /// A culled draw's `firstInstance` is its instance slot with its level of detail above this
    /// bit (`gl_InstanceIndex >> LOD_LEVEL_SHIFT`).
    pub const LOD_LEVEL_SHIFT: u32 = 29;
    /// The instance slot in a culled draw's `gl_InstanceIndex`.
    pub const LOD_SLOT_MASK: u32 = 536870911;
    /// Culling mode: every live instance is drawn.
    pub const CULL_MODE_OFF: u32 = 0;
    /// Culling mode: instances outside the view frustum are skipped.
    pub const CULL_MODE_FRUSTUM: u32 = 1;
    /// Culling mode: frustum, then two-phase hierarchical-Z occlusion.
    pub const CULL_MODE_OCCLUSION: u32 = 2;
    /// Culling pass: the first phase (frustum; occlusion by last frame's visibility).
    pub const CULL_PASS_FIRST: u32 = 0;
    /// Culling pass: the second phase (the rest against this frame's depth pyramid).
    pub const CULL_PASS_SECOND: u32 = 1;
    /// Culling pass: the blended instances in their back-to-front order (a command each).
    pub const CULL_PASS_ORDERED: u32 = 2;
    /// Culling pass: the shadow-map views (a list per view).
    pub const CULL_PASS_SHADOW_VIEWS: u32 = 3;
    /// Most levels of the depth pyramid (a 65536-pixel side).
    pub const HIZ_MAX_LEVELS: u32 = 16;
    /// Depth-pyramid levels one dispatch writes (an 8×8 workgroup's block and the three above it:
    /// `shaders/include/depth_pyramid_build.glsl`).
    pub const HIZ_LEVELS_PER_DISPATCH: u32 = 4;

    /// The camera as the shaders see it.
    #[layout(std430)]
    pub struct GpuCamera {
        /// World to view.
        pub view: Mat4,
        /// View to clip (reverse-Z, infinite far plane).
        pub proj: Mat4,
        /// World to clip.
        pub view_proj: Mat4,
        /// Clip to world.
        pub inv_view_proj: Mat4,
        /// Camera position in world space.
        pub position: Vec3,
        /// Multiplier applied to radiance before tone mapping.
        pub exposure: f32,
        /// Render target size in pixels.
        pub viewport_size: Vec2,
        /// 1 / viewport size.
        pub inv_viewport_size: Vec2,
        /// Uniform ambient radiance (scaled by material occlusion).
        pub ambient: Vec3,
        /// Seconds on the scene's clock, for decals fading at the end of their lifetime
        /// (`GpuDecal::life_scale`). It may stand still while no decal is fading, so that
        /// frames in which only time passed upload nothing.
        pub time: f32,
        /// The distance fade (start, end, in metres) of decals that have none of their own;
        /// (∞, ∞) or (0, 0) never fades.
        pub decal_fade: Vec2,
        /// Temporal anti-aliasing's sub-pixel offset this frame, in NDC units: `proj`,
        /// `view_proj` and `inv_view_proj` include it (0 without temporal anti-aliasing).
        pub jitter: Vec2,
        /// Temporal anti-aliasing's frame count (it never repeats; 0 without temporal
        /// anti-aliasing): what stochastic passes whose result the history averages seed
        /// their samples with (soft shadows' points on a light).
        pub taa_frame: u32,
        /// Padding to 16 bytes.
        pub taa_pad: [u32; 3],
        /// World to clip without the jitter: where motion vectors measure from.
        pub motion_view_proj: Mat4,
        /// The previous frame's `motion_view_proj` (this frame's when there is no history).
        pub prev_view_proj: Mat4,
    }

    /// An instance that moved or was posed since the previous frame: the motion-vector pass
    /// draws it (`crate::motion`, `shaders/motion.vert`), its draw's `first_instance` naming
    /// this record.
    #[layout(std430)]
    pub struct GpuMover {
        /// Object to world in the previous frame.
        pub prev_model: Mat4,
        /// The instance's slot.
        pub slot: u32,
        /// Its mesh's first vertex in the mesh pool (`vertexOffset`).
        pub vertex_offset: u32,
        /// Device address of a posed mesh's previous positions (a vec4 per vertex, behind its
        /// vertices); 0 for a rigid mesh.
        pub previous: u64,
    }

    /// One drawn mesh instance.
    #[layout(std430)]
    pub struct GpuInstance {
        /// Object to world.
        pub model: Mat4,
        /// Inverse-transpose of `model`, for normals.
        pub normal_model: Mat4,
        /// Slot of the instance's material in the material table.
        pub material: u32,
        /// Decal receiver layers: a decal lands here when its mask shares a bit with these.
        pub decal_layers: u32,
        /// The instance's mesh (its index in the renderer's mesh table; set by the mirror).
        pub mesh: u32,
        /// 1 for a live instance, 0 for a free slot (the scene TLAS leaves free slots inactive).
        pub live: u32,
    }

    /// A metallic-roughness material.
    #[layout(std430)]
    pub struct GpuMaterial {
        /// Linear base colour and alpha.
        pub base_color: [f32; 4],
        /// Emitted radiance.
        pub emissive: [f32; 3],
        /// Strength of the normal map's XY.
        pub normal_scale: f32,
        /// Metallic factor.
        pub metallic: f32,
        /// Perceptual roughness factor.
        pub roughness: f32,
        /// Alpha below which masked materials are discarded.
        pub alpha_cutoff: f32,
        /// How much the occlusion texture darkens ambient light.
        pub occlusion_strength: f32,
        /// Bindless slot of the base colour texture (sRGB).
        pub base_color_tex: u32,
        /// Bindless slot of the metallic (B) / roughness (G) texture (glTF).
        pub metallic_roughness_tex: u32,
        /// Bindless slot of the tangent-space normal map.
        pub normal_tex: u32,
        /// Bindless slot of the occlusion texture (R).
        pub occlusion_tex: u32,
        /// Bindless slot of the emissive texture (sRGB).
        pub emissive_tex: u32,
        /// `MATERIAL_*` flags.
        pub flags: u32,
        /// Blended surfaces: how far the background seen through them is displaced, in metres
        /// at the surface (`thickness × (1 − 1/ior)`; 0 for thin surfaces).
        pub refraction: f32,
        /// Padding to 16 bytes.
        pub pad: u32,
    }

    /// One punctual light.
    #[layout(std430)]
    pub struct GpuLight {
        /// World position (point, spot).
        pub position: Vec3,
        /// Distance at which the light's contribution reaches zero.
        pub range: f32,
        /// Colour × intensity (candela; lux for directional lights).
        pub color: Vec3,
        /// A `LIGHT_*` kind (`LightKind` in Rust).
        pub kind: u32,
        /// Direction the light travels (spot, directional), unit length; an area light's facing
        /// (its emitting side's normal).
        pub direction: Vec3,
        /// 1 / (cos inner − cos outer). With `spot_offset` and `cone_cos`, an area light's
        /// axis in its plane (`GpuLight::area_right`): a rectangle's half-width vector, a unit
        /// vector for a disk. Area lights have no cone, so the record stays 64 bytes.
        pub spot_scale: f32,
        /// −cos outer × `spot_scale`.
        pub spot_offset: f32,
        /// Cosine of the spot cone's outer half-angle (light culling's cone test).
        pub cone_cos: f32,
        /// Sine of the spot cone's outer half-angle.
        pub cone_sin: f32,
        /// The light's size (0: a point; hard shadows): its sphere's radius in metres (point,
        /// spot), the tangent of its disc's angular radius (directional), a rectangle's half
        /// height or a disk's radius in metres. Ray-traced
        /// shadows aim at a point of it that changes from pixel to pixel and frame to frame.
        pub size: f32,
    }

    /// One decal projector (seed 000 §4.1, "reduced form for shading"). The decal's box is
    /// `[-0.5, 0.5]³` in decal space; it projects along −Z. A zeroed record (a free slot) has no
    /// receiver bits and so never applies.
    #[layout(std430)]
    pub struct GpuDecal {
        /// World to decal space.
        pub world_to_decal: Mat4,
        /// UVs of the box corners at local (−x,−y) and (+x,−y).
        pub uv01: [f32; 4],
        /// UVs of the corners at (+x,+y) and (−x,+y).
        pub uv23: [f32; 4],
        /// Slot in the decal material table (the low `DECAL_CHANNEL_SHIFT` bits) and blending
        /// channel, below `DECAL_CHANNELS` (the bits above): one word, so that the record, with
        /// its lifetime fade, stays 128 bytes (one cache line on the GPUs we measure on).
        pub material_channel: u32,
        /// Weight within the channel.
        pub weight: f32,
        /// Receiver layers the decal lands on (0 in free slots: never applies).
        pub receivers: u32,
        /// Overall opacity.
        pub opacity: f32,
        /// Angle fade as two half floats (scale, offset): fade = saturate(cos θ × scale +
        /// offset); (0, 1) disables it.
        pub angle_fade: u32,
        /// Distance fade as two half floats (start, end) in metres from the camera: full
        /// strength nearer than start, none beyond end; (0, 0) takes the camera's default
        /// (`GpuCamera::decal_fade`), (∞, ∞) never fades.
        pub distance_fade: u32,
        /// Lifetime fade: opacity × saturate(`GpuCamera::time` × scale + offset); (0, 1)
        /// disables it. The fade is evaluated on the GPU so that an ageing decal is never
        /// re-uploaded.
        pub life_scale: f32,
        /// See `life_scale`.
        pub life_offset: f32,
    }

    /// What a decal applies.
    #[layout(std430)]
    pub struct GpuDecalMaterial {
        /// Albedo factor (rgb) and opacity (a).
        pub base_color: [f32; 4],
        /// Emitted radiance (linear rgb, HDR), × the emissive texture and the decal's coverage.
        pub emissive: [f32; 3],
        /// Bindless slot of the RGBA texture (alpha is coverage).
        pub base_color_tex: u32,
        /// Bindless slot of the normal map.
        pub normal_tex: u32,
        /// Bindless slot of the metallic (B) / roughness (G) texture.
        pub metallic_roughness_tex: u32,
        /// Bindless slot of the emissive texture (rgb, sRGB).
        pub emissive_tex: u32,
        /// `DECAL_*` flags.
        pub flags: u32,
        /// Normal map XY strength.
        pub normal_scale: f32,
        /// Roughness to blend in.
        pub roughness: f32,
        /// Metallic to blend in.
        pub metallic: f32,
        /// Padding.
        pub pad: f32,
    }

    /// A decal's axis-aligned box as acceleration-structure builds read it (`VkAabbPositionsKHR`
    /// at the start of a 32-byte stride), and the decal record it belongs to. The boxes of live
    /// decals are kept dense (a despawn moves the last box into the hole), so the decal BLAS is
    /// built over exactly the live boxes and its primitive index maps to a record through `slot`.
    #[layout(scalar)]
    pub struct GpuAabb {
        /// Minimum corner.
        pub min: [f32; 3],
        /// Maximum corner.
        pub max: [f32; 3],
        /// Slot of the record the box belongs to: the decal in the decal table, or the light (`NO_DECAL` for padding boxes).
        pub slot: u32,
        /// A decal on a skin: its skinned instance's slot + 1, whose posed bounds clustered
        /// decals bin it by (the box is in the rest pose); 0 otherwise. (It also pads the box
        /// to the 8-byte multiple a build's AABB stride must be.)
        pub owner: u32,
    }

    /// How this frame assigns lights to pixels and where the light-culling and shadow buffers
    /// are (uploaded only when it changes).
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuLighting {
        /// Address of the light tile buffer: statistics, the grid and the index list
        /// (`shaders/include/light_tiles.glsl`).
        pub light_tiles: u64,
        /// Address of the tiles' view-space frusta (`GpuTileFrustum` per tile).
        pub tile_frusta: u64,
        /// Address of the shadow visibility words.
        pub shadow_bits: u64,
        /// Address of the scene TLAS (0 without).
        pub scene_tlas: u64,
        /// Address of the ray-query lights' TLAS (0 unless lights are found by ray queries).
        pub light_tlas: u64,
        /// Address of the ray-query lights' boxes (`GpuAabb` per light slot, box i for slot i).
        pub light_boxes: u64,
        /// Address of the lights no box can hold (directional lights, unbounded ranges), which
        /// every pixel loops over with ray-query lights: a count, then light slots.
        pub unbounded_lights: u64,
        /// Address of the scene BLAS of each mesh (u64 per mesh, 0 for none).
        pub scene_blas_table: u64,
        /// Address of the scene TLAS's instance records (written by the scene instance pass).
        pub scene_instances: u64,
        /// Address of the shadow tints (0 without): `SHADOW_TINT_SLOTS` words per pixel, row
        /// after row, each the transmittance (RGB8) and 1 + the list entry it belongs to (top
        /// 8 bits; 0 for an empty slot) (`shaders/include/light_tiles.glsl`).
        pub shadow_tints: u64,
        /// A `LIGHTS_*` value.
        pub mode: u32,
        /// Tile side in pixels (8, 16 or 32).
        pub tile_size: u32,
        /// Tiles across.
        pub tiles_x: u32,
        /// Tiles down.
        pub tiles_y: u32,
        /// Entries the light index list has room for.
        pub list_capacity: u32,
        /// Rows of shadow words there is room for (a row is one word per pixel of a tile, for
        /// 32 list entries).
        pub shadow_rows: u32,
        /// `LIGHT_CULL_AABB`, `SHADOW_*` flags.
        pub flags: u32,
        /// Instance slots the scene TLAS is built over.
        pub instance_count: u32,
        /// Entries of the scene BLAS table.
        pub blas_count: u32,
        /// Boxes the light box pass writes (the light BLAS's build count).
        pub light_box_count: u32,
        /// Shadow maps: a tile's side in texels.
        pub shadow_map_tile: u32,
        /// Shadow maps: tiles across the atlas.
        pub shadow_map_columns: u32,
        /// Radiance where no geometry is drawn (compute shading writes it to sky pixels).
        pub clear_color: Vec4,
        /// Address of the culling records (`GpuCullRecord` per instance slot: world bounds that
        /// follow a skinned instance's pose), where clustered decals bin decals on a skin. Set by
        /// the scene's upload, after the tables have their buffers for the frame.
        pub culls: u64,
        /// Address of the reflection pass's statistics (`REFLECTION_STATS` words, zeroed by the
        /// pass each frame; 0 when reflections are off): see `shaders/include/reflections.glsl`.
        pub reflection_stats: u64,
        /// Reflections: surfaces at least this rough reflect nothing (the ambient term stays);
        /// reflection fades out over the last quarter below it.
        pub reflection_cutoff: f32,
        /// `REFLECT_*` flags (0: reflections off).
        pub reflection_flags: u32,
        /// Address of screen-space reflections' nearest-depth pyramid
        /// (`shaders/include/depth_pyramid.glsl`; 0 unless they run).
        pub reflection_hiz: u64,
        /// Address of the environment record (`GpuEnvironment`; 0 without an environment).
        pub environment: u64,
        /// Address of the environment's last filtering job (`GpuEnvironmentJob`; 0 before the
        /// first), which the filtering passes read on the frame that filters it.
        pub environment_job: u64,
        /// The environment's rotation about +Y as (cos, sin).
        pub environment_rotation: Vec2,
        /// Multiplier of the environment's radiance.
        pub environment_intensity: f32,
        /// `ENVIRONMENT_*` flags (0: no environment).
        pub environment_flags: u32,
        /// Levels of the specular cube − 1 (the level of roughness 1).
        pub environment_max_level: f32,
        /// The display transform's tone mapper (`TONEMAP_*`).
        pub tonemapper: u32,
        /// Bloom: how much of the image its blurred copy replaces (0: no bloom).
        pub bloom_intensity: f32,
        /// Bloom: levels of the pyramid (`shaders/include/bloom.glsl`).
        pub bloom_levels: u32,
        /// Bloom: address of the pyramid (0 without bloom).
        pub bloom: u64,
        /// Ambient occlusion: how far occluders count, in metres (`crate::occlusion`).
        pub occlusion_radius: f32,
        /// Ambient occlusion: rays per pixel (traced occlusion).
        pub occlusion_rays: u32,
        /// Auto-exposure: address of its record (`GpuExposure`; 0: the camera's exposure).
        pub exposure: u64,
        /// Auto-exposure: compensation in stops (positive brightens).
        pub exposure_compensation: f32,
        /// Auto-exposure: the darkest scene it exposes for, as an EV100.
        pub exposure_min_ev100: f32,
        /// Auto-exposure: the brightest scene it exposes for, as an EV100.
        pub exposure_max_ev100: f32,
        /// Auto-exposure: adaptation rate per second (the share of the way to the target covered
        /// in one second is 1 − e^−rate).
        pub exposure_rate: f32,
        /// Address of the debug builds' check of the tone mapper's input (a counter of pixels
        /// that were not finite: `crate::present::check`; 0 in release builds).
        pub display_check: u64,
        /// Address of this frame's movers (`GpuMover` each: instances that moved or were posed
        /// since the previous frame), which the motion-vector pass draws (`crate::motion`).
        pub movers: u64,
        /// How far a ray's origin is lifted off the surface, per metre of its distance to the
        /// camera, beyond the 0.1 % every ray gets: the world size of `lod_pixels` pixels at
        /// 1 m, the most a level of detail may stray from the full mesh the rays trace
        /// (`crate::lod`; 0 with levels of detail off).
        pub lod_lift: f32,
        /// Direct lighting (`crate::lights::sampling`): a pixel whose light list holds more
        /// lights than this samples their shadows (one ray to a light drawn in proportion to its
        /// unshadowed light, `shaders/include/direct_sampling.glsl`) instead of a ray per light;
        /// `u32::MAX` while no pixel samples. With ray-query lights, which find a pixel's lights
        /// while shading it (`shaders/include/ray_query_lights.glsl`): the lights a pixel traces a
        /// ray each before it draws from the rest.
        pub sampled_lights_above: u32,
        /// Address of the particle system's state (`GpuParticleState`, `crate::particles`; 0
        /// while no emitter or particle exists).
        pub particles: u64,
        /// Address of the particles' decal ring's records (`GpuDecal` per place); without a
        /// ring, this record's own (a valid address: shaders read its place 0 then, so that no
        /// load, hoisted out of its branch by a compiler, reads from address 0).
        pub decal_ring: u64,
        /// Address of the ring's boxes (`GpuAabb` per place); without a ring, this record's.
        pub decal_ring_boxes: u64,
        /// Address of the ring's TLAS (0: none), traced after the scene's decal TLAS.
        pub decal_ring_tlas: u64,
        /// Places of the ring (0: none), whose boxes the decal enumeration takes after the
        /// scene's decals'.
        pub decal_ring_room: u32,
        /// Places of the ring in one BLAS of its structure: instance k of the ring's TLAS holds
        /// the places from k × this on (`crate::particles::ring_accel`).
        pub decal_ring_segment: u32,
        /// High-water mark of light slots; empty slots have kind `LIGHT_NONE`. Here rather than in
        /// the push constants: see [`ScenePush`].
        pub light_count: u32,
        /// Direct lighting: how many of `suns` hold a directional light's slot.
        pub sun_count: u32,
        /// Direct lighting: the slots of the first `DIRECT_LIGHT_SUNS` directional lights, which a
        /// sampling pixel traces a ray to each rather than sampling them with the rest.
        pub suns: [u32; 4],
    }

    /// One particle of the pool (`crate::particles`). A slot whose `lifetime` is 0 is free.
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuParticle {
        /// World position, metres.
        pub position: Vec3,
        /// Seconds since it was emitted.
        pub age: f32,
        /// World velocity, metres per second.
        pub velocity: Vec3,
        /// Seconds it lives (0: a free slot).
        pub lifetime: f32,
        /// The emitter slot whose parameters it follows.
        pub emitter: u32,
        /// Its random seed (size and colour variation, flipbook start).
        pub seed: u32,
        /// `PARTICLE_*` flags.
        pub flags: u32,
        /// The normal of the surface it touched last, octahedral (two snorm16; 0: none).
        pub contact_normal: u32,
    }

    /// An emitter's parameters (`crate::particles::EmitterDesc`), by emitter slot.
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuEmitter {
        /// Where particles are born: the emitter's world transform (the cone's axis is its +Y).
        pub transform: Mat4,
        /// Colour at birth, premultiplied: rgb is the linear radiance added where the sprite
        /// covers (above 1 glows and blooms; × the light taken when `lit`), alpha how much of
        /// what is behind it hides (0: light added, nothing hidden).
        pub color_start: Vec4,
        /// Colour at death (the colour moves linearly from one to the other over the life).
        pub color_end: Vec4,
        /// Acceleration, m/s² (gravity and wind).
        pub acceleration: Vec3,
        /// Drag: the share of velocity lost per second is 1 − e^−drag.
        pub drag: f32,
        /// Quad side at birth, metres.
        pub size_start: f32,
        /// Quad side at death, metres.
        pub size_end: f32,
        /// Slowest launch speed, m/s.
        pub speed_min: f32,
        /// Fastest launch speed, m/s.
        pub speed_max: f32,
        /// Shortest life, seconds.
        pub lifetime_min: f32,
        /// Longest life, seconds.
        pub lifetime_max: f32,
        /// Cosine of the launch cone's half-angle around +Y (1: straight up, −1: every way).
        pub cone_cos: f32,
        /// Radius of the sphere particles are born in, metres (0: at the origin).
        pub spawn_radius: f32,
        /// `PARTICLE_CONTACT_*`.
        pub contact: u32,
        /// The share of speed along the normal kept by a bounce.
        pub restitution: f32,
        /// The share of speed along the surface kept by a bounce.
        pub friction: f32,
        /// Bindless texture slot of the sprite (`TEXTURE_WHITE`: a soft round dot).
        pub texture: u32,
        /// Flipbook frames across and down the texture (1×1: a single image), x in the low 16
        /// bits and y in the high.
        pub flipbook: u32,
        /// How far (metres) behind the surface in front of it a particle fades out (soft
        /// particles; 0: a hard edge).
        pub softness: f32,
        /// How much of the scene's light it takes (0: emissive only, 1: lit like a matte
        /// surface facing the light).
        pub lit: f32,
        /// Streaks: the quad is drawn along the particle's motion on screen, as long as the
        /// distance it covers in this many seconds (plus its size; 0: a square).
        pub stretch: f32,
        /// The decal a landing particle leaves: its decal material slot (`NO_DECAL`: none).
        pub decal_material: u32,
        /// The left decal's box: side along the surface, metres (0: no decal, so that a
        /// zeroed record leaves none).
        pub decal_size: f32,
        /// The left decal's box: depth across the surface, metres.
        pub decal_depth: f32,
        /// Seconds the left decal lives, its fade included (0: until the ring overwrites it).
        pub decal_lifetime: f32,
        /// Seconds over which the left decal fades out at the end of its life.
        pub decal_fade: f32,
        /// Padding to 16 bytes.
        pub decal_pad: [u32; 3],
    }

    /// One emitter's share of a frame's new particles: invocations [`first`, `first + count`)
    /// of the emission pass start particles of `emitter`.
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuEmission {
        /// Emitter slot.
        pub emitter: u32,
        /// The first invocation of the job.
        pub first: u32,
        /// Particles it starts.
        pub count: u32,
        /// Seed of its random numbers (different every frame).
        pub seed: u32,
    }

    /// The particle system's state (`crate::particles`): the frame's input, which the CPU writes,
    /// then what the GPU counts. One buffer, whose address the lighting record holds; the jobs
    /// follow it.
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuParticleState {
        /// Address of the particle pool (`GpuParticle` × `capacity`).
        pub pool: u64,
        /// Address of the free list (`capacity` slots; the first `free_count` are free).
        pub free_list: u64,
        /// Address of the drawn list (the slots alive after this frame's simulation).
        pub alive_list: u64,
        /// Address of the drawn particles' light, by drawn-list entry (RGB as three halves and
        /// a spare half: `particles_light.comp` writes it, the drawing reads it).
        pub light_list: u64,
        /// Address of the GPU-born decals' records (`GpuDecal` × `decal_room`): the ring a
        /// landing particle's decal is written into, oldest overwritten first.
        pub decals: u64,
        /// Address of the GPU-born decals' boxes (`GpuAabb` × `decal_room`, slot `GPU_DECAL |
        /// i`; `NO_DECAL` until written).
        pub decal_boxes: u64,
        /// Address of the emitter table (`GpuEmitter` per emitter slot).
        pub emitters: u64,
        /// Slots of the pool.
        pub capacity: u32,
        /// This frame's emission jobs (`GpuEmission`, after this record).
        pub job_count: u32,
        /// This frame's new particles (the emission pass's invocations).
        pub spawn_count: u32,
        /// Seconds since the previous frame.
        pub delta: f32,
        /// Whether particles collide with surfaces (1: the depth buffer's, or the scene's
        /// structure's when the frame traces it) or pass through everything (0).
        pub collide: u32,
        /// Places in the decal ring (a power of two).
        pub decal_room: u32,
        /// GPU-written from here: free slots in the free list (signed while the emission pass
        /// pops).
        pub free_count: u32,
        /// Particles started since the system was created.
        pub spawned: u32,
        /// Particles that touched a surface since the system was created (once each).
        pub landed: u32,
        /// Particles not started because the pool was full, since the system was created.
        pub dropped: u32,
        /// Decals left by landing particles since the pool was made (the ring's place of the
        /// next is this modulo `decal_room`, a power of two).
        pub decals_born: u32,
        /// Draws of the drawing pass (1; the count of its `vkCmdDrawIndirectCount`).
        pub draw_count: u32,
        /// Padding.
        pub counters_pad: [u32; 2],
        /// The particles alive after the simulation, the drawn list's length, in word 1 (the
        /// simulation counts them with atomics; the other words are 0).
        pub draw: [u32; 4],
        /// The drawing passes' indirect draw, written by `particles_light.comp` from the drawn
        /// list's length: `PARTICLE_SPRITE_VERTICES` a particle in one instance (the vertex
        /// shader finds the particle from the vertex index), first vertex, first instance.
        pub sprites: [u32; 4],
    }

    /// Auto-exposure's state on the GPU (`crate::exposure`): this frame's luminance histogram
    /// (cleared by the pass that reads it) and the exposure the display transform applies.
    #[layout(std430)]
    pub struct GpuExposure {
        /// Pixels per log2-luminance bin (`EXPOSURE_BINS`).
        pub histogram: [u32; 128],
        /// The exposure applied (radiance multiplier); 0 before the first adaptation.
        pub exposure: f32,
        /// The scene's average luminance the exposure is adapting to (the histogram's mean
        /// between its 10th and 90th percentiles, in log2).
        pub luminance: f32,
        /// The adapted EV100 (less the compensation): the exposure is 1.44 / 2^ev100, which
        /// puts a luminance of 2^ev100 / 8 at 18 % grey.
        pub ev100: f32,
        /// Frames adapted since the state was reset.
        pub frames: u32,
    }

    /// What the environment's filtering passes make the environment from
    /// (`crate::environment`): written by the CPU into a host-visible buffer, with the map's
    /// texels after it, for the frame that filters a new source (`GpuLighting::environment_job`).
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuEnvironmentJob {
        /// Direction towards the sun (xyz; the procedural sky) and the cosine of its disc's
        /// angular radius (w).
        pub sun: Vec4,
        /// The sun's illuminance (rgb, lux: the directional light's colour × illuminance).
        pub sun_color: Vec4,
        /// The uniform environment's radiance (`ENVIRONMENT_UNIFORM`).
        pub color: Vec4,
        /// Address of the equirectangular map's texels (`ENVIRONMENT_MAP`; valid on the frame
        /// that filters the job only): RGB32F rows, the first looking up (+Y), the middle column
        /// along +X, longitude growing towards +Z.
        pub source: u64,
        /// The map's width and height in texels.
        pub source_size: [u32; 2],
        /// An `ENVIRONMENT_*` mode.
        pub mode: u32,
        /// Side of the cubes' faces in texels.
        pub face: u32,
        /// Levels of the radiance cube.
        pub source_levels: u32,
        /// Levels of the specular cube.
        pub specular_levels: u32,
    }

    /// The environment as shading reads it (`GpuLighting::environment`), written on the GPU by
    /// the irradiance pass whenever the source changes.
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuEnvironment {
        /// Diffuse irradiance / π as nine spherical-harmonic coefficients (rgb), already
        /// convolved with the cosine lobe: `E(n)/π = Σ sh[i] Y_i(n)`.
        pub sh: [Vec4; 9],
        /// The job's `sun` (the sky pass draws its disc).
        pub sun: Vec4,
        /// The job's `sun_color`.
        pub sun_color: Vec4,
    }

    /// One shadow-map view (a tile of the atlas): a spot light's, one cube face of a point
    /// light's, or a directional light's fitted to the camera's view.
    #[layout(std430)]
    pub struct GpuShadowView {
        /// World to the light's clip space (reverse-Z).
        pub view_proj: Mat4,
        /// World size of one texel: at 1 m from the light (perspective), or anywhere
        /// (orthographic).
        pub texel: f32,
        /// 1 for an orthographic (directional) view.
        pub ortho: u32,
        /// Padding to 16 bytes.
        pub pad: [u32; 2],
    }

    /// A light tile's frustum in view space: four side planes through the eye, with inward
    /// normals (xyz) and offsets (w, zero through the eye), and the tile's extent on the plane
    /// one metre in front of the eye.
    #[layout(std430)]
    pub struct GpuTileFrustum {
        /// Left side plane.
        pub left: Vec4,
        /// Right side plane.
        pub right: Vec4,
        /// Top side plane.
        pub top: Vec4,
        /// Bottom side plane.
        pub bottom: Vec4,
        /// View-space x min, x max, y min, y max of the tile at one metre.
        pub extent: Vec4,
    }

    /// Where a mesh's vertices and indices live (the visibility buffer fetches them).
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuMeshInfo {
        /// Device address of the first vertex.
        pub vertices: u64,
        /// Device address of the first index.
        pub indices: u64,
        /// The first index's place in the mesh pool's buffer, in indices (an indirect draw's
        /// `firstIndex`).
        pub first_index: u32,
        /// Number of indices (0 for a free mesh id: nothing is drawn).
        pub index_count: u32,
        /// The first vertex's place in the mesh pool's buffer, in vertices (`vertexOffset`).
        pub vertex_offset: u32,
        /// Number of vertices.
        pub vertex_count: u32,
        /// Device address of the rest-pose vertices, in the same order: `vertices` itself for
        /// a mesh that is not posed; for a posed copy (`render/src/skinning`), its skinned
        /// source's. Decals attached to a skin are evaluated at the rest-pose position.
        pub rest: u64,
        /// Device address of the joints and weights (`GpuSkinVertex` per vertex) of a skinned
        /// mesh and its posed copies; 0 for a mesh without a skin.
        pub skin: u64,
        /// Device address of the morph targets' offsets (`GpuMorphDelta`, target after target,
        /// `vertex_count` each) of a mesh with morph targets and its posed copies; 0 without.
        pub morphs: u64,
        /// Device address of the skinning pass's table of the levels of detail's vertices
        /// (`MeshLods::skin_table`: per level its first word and its vertex count, each
        /// vertex's coarsest level, then each level's vertices), for a skinned mesh with levels
        /// and its posed copies; 0 without.
        pub vertex_levels: u64,
        /// Number of morph targets.
        pub morph_targets: u32,
        /// Coarser levels of detail (`render/src/lod`; 0 to `LOD_LEVELS`).
        pub lod_levels: u32,
        /// The mesh's smallest texture coordinate: a vertex's UV is `uv_offset + uv × uv_scale`
        /// ([`GpuVertex::uv`]).
        pub uv_offset: [f32; 2],
        /// Each coarser level's first index in the mesh pool's buffer (its `firstIndex`); its
        /// triangles follow level 0's in the mesh's index range.
        pub lod_first: [u32; 4],
        /// Each coarser level's number of indices.
        pub lod_count: [u32; 4],
        /// Each coarser level's geometric error as a fraction of the diagonal of the mesh's
        /// bounds.
        pub lod_error: Vec4,
        /// The span of the mesh's texture coordinates (see `uv_offset`; 1 where they do not
        /// vary).
        pub uv_scale: [f32; 2],
        /// Padding to 16 bytes.
        pub pad: [u32; 2],
    }

    /// One vertex's offsets in one morph target (glTF 2.0 §3.7.2.2), added in proportion to the
    /// target's weight before skinning.
    #[layout(scalar)]
    pub struct GpuMorphDelta {
        /// Position offset.
        pub position: [f32; 3],
        /// Normal offset.
        pub normal: [f32; 3],
    }

    /// Joints and weights of one vertex of a skinned mesh: four joint indices as 16-bit halves
    /// and four weights as 16-bit unorm halves (`unpackUnorm2x16`), summing to 1.
    #[layout(std430)]
    pub struct GpuSkinVertex {
        /// Joints 0 (low half) and 1.
        pub joints01: u32,
        /// Joints 2 (low half) and 3.
        pub joints23: u32,
        /// Weights 0 (low half) and 1.
        pub weights01: u32,
        /// Weights 2 (low half) and 3.
        pub weights23: u32,
    }

    /// One joint's skinning matrix (joint's world × inverse bind matrix, in the posed mesh's
    /// object space), as the three rows of a 3×4 affine matrix.
    #[layout(std430)]
    pub struct GpuJointMatrix {
        /// First row.
        pub x: Vec4,
        /// Second row.
        pub y: Vec4,
        /// Third row.
        pub z: Vec4,
    }

    /// One posed mesh the skinning pass writes this frame.
    #[layout(std430)]
    pub struct GpuSkinJob {
        /// The posed mesh (its `GpuMeshInfo` names its source's rest vertices and skin).
        pub mesh: u32,
        /// Its first joint matrix in the palette.
        pub palette: u32,
        /// Which vertices it skins and what its previous positions are: the level of detail
        /// whose vertices it skins in the low byte (`SKIN_LEVEL_MASK`; 0: every vertex), its last
        /// skinning's level in the next (`SKIN_PREVIOUS_SHIFT`: a vertex that skinning did not
        /// write has no previous position), and `SKIN_FIRST` the first time it is posed (its
        /// previous positions are set to the new ones).
        pub levels: u32,
        /// Its first morph weight in the weights array (the mesh's `morph_targets` of them).
        pub weights: u32,
    }

    /// The skinning pass's push constants (its pipeline has a layout of its own).
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuSkinPush {
        /// Address of the mesh table.
        pub meshes: u64,
        /// Address of this frame's jobs.
        pub jobs: u64,
        /// Address of the joint palette (`GpuJointMatrix` each).
        pub palette: u64,
        /// Address of the morph weights (floats).
        pub weights: u64,
        /// Number of jobs.
        pub job_count: u32,
        /// Workgroups per job along x (the largest mesh's vertices / 64).
        pub groups: u32,
    }

    /// What GPU culling knows of an instance slot, kept by change detection like the instance
    /// record (written when the transform, mesh or material changed).
    #[layout(std430)]
    pub struct GpuCullRecord {
        /// World-space bounds, minimum corner.
        pub min: Vec3,
        /// `CULL_*` flags (0 for a free slot).
        pub flags: u32,
        /// World-space bounds, maximum corner.
        pub max: Vec3,
        /// The instance's mesh.
        pub mesh: u32,
    }

    /// One `VkDrawIndexedIndirectCommand`, as the culling passes write it.
    #[layout(scalar)]
    pub struct GpuDrawCommand {
        /// Indices to draw.
        pub index_count: u32,
        /// 1, or 0 for an ordered command whose instance was culled.
        pub instance_count: u32,
        /// First index in the mesh pool.
        pub first_index: u32,
        /// First vertex in the mesh pool (a signed `vertexOffset`, never negative here).
        pub vertex_offset: u32,
        /// The instance slot: shaders find their record at `gl_InstanceIndex`.
        pub first_instance: u32,
    }

    /// What the culling passes read of a frame: where everything is and how the lists are laid
    /// out (`shaders/include/culling.glsl`; written by the CPU into its frame slot's buffer only
    /// when it changes).
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuCullParams {
        /// World to clip of the view culled against (the camera's, or the frozen one).
        pub view_proj: Mat4,
        /// Address of the culling records (`GpuCullRecord` per instance slot).
        pub records: u64,
        /// Address of the mesh table (`GpuMeshInfo` per mesh).
        pub meshes: u64,
        /// Address of the draw buffer: the header (`CULL_HEADER` words, then a count per shadow
        /// view), then the commands.
        pub draws: u64,
        /// Address of the visibility bits (one per instance slot: drawn last frame).
        pub visibility: u64,
        /// Address of the depth pyramid: its levels one after another
        /// (`shaders/include/depth_pyramid.glsl`).
        pub hiz: u64,
        /// Address of the blended instances' back-to-front order (instance slots).
        pub order: u64,
        /// Address of the shadow maps' views buffer (`ScenePush::shadow_views`).
        pub shadow_views: u64,
        /// Address of the level of detail each instance slot drew last (a word per slot; 0 when
        /// levels of detail are off).
        pub lods: u64,
        /// Instance slots to visit.
        pub count: u32,
        /// A `CULL_MODE_*` value.
        pub mode: u32,
        /// Word offset of the commands in the draw buffer.
        pub commands: u32,
        /// Commands of one phase's list (the second list starts this many after the first).
        pub list_stride: u32,
        /// Command index of the ordered (blended) commands.
        pub ordered_first: u32,
        /// Entries of the blended order.
        pub ordered_count: u32,
        /// Command index of shadow view 0's list.
        pub shadow_first: u32,
        /// Commands each shadow view's list has room for.
        pub shadow_stride: u32,
        /// Shadow views drawn this frame.
        pub shadow_count: u32,
        /// Depth-pyramid levels.
        pub hiz_levels: u32,
        /// Depth size in pixels (the pyramid is built from it).
        pub viewport: Vec2,
        /// Command index of each batch's first command within a list.
        pub batch_start: [u32; 4],
        /// Commands each batch has room for.
        pub batch_capacity: [u32; 4],
        /// 1 while the culling view is frozen: visibility is read, never written.
        pub frozen: u32,
        /// Levels of detail: the most pixels a level's error may cover on screen (0: level 0
        /// always).
        pub lod_pixels: f32,
        /// Levels of detail: an instance moves to a coarser level only when that level's error
        /// covers at most this many pixels (hysteresis).
        pub lod_coarsen_pixels: f32,
        /// Padding to 16 bytes.
        pub pad: u32,
    }

    /// The culling passes' push constants (their pipelines have a layout of their own).
    #[layout(std430)]
    #[derive(Default)]
    pub struct GpuCullPush {
        /// Address of this frame's `GpuCullParams`.
        pub params: u64,
        /// A `CULL_PASS_*` value.
        pub pass: u32,
        /// In the depth-pyramid build, the level being written.
        pub level: u32,
    }

    /// One vertex as the mesh pool holds it and the mesh pipelines read it (binding 0,
    /// interleaved), 24 bytes (`crate::scene::vertex` packs it; `vertex.glsl` unpacks it).
    #[layout(scalar)]
    pub struct GpuVertex {
        /// Object-space position.
        pub position: [f32; 3],
        /// Object-space normal, octahedral: two snorm16 (`unpackSnorm2x16`).
        pub normal: u32,
        /// Object-space tangent, octahedral like the normal, with the bitangent sign in bit 0
        /// (set: −1) in place of the first component's lowest bit.
        pub tangent: u32,
        /// Texture coordinate 0: two unorm16 over the mesh's UV range
        /// (`GpuMeshInfo::uv_offset`, `uv_scale`).
        pub uv: u32,
    }

    /// Bytes of a [`GpuVertex`] (the mesh pool's stride).
    pub const VERTEX_BYTES: u32 = 24;

    /// The camera record (block in scene.glsl).
    buffer_reference CameraRef;
    /// The instance table (block in scene.glsl).
    buffer_reference InstancesRef;
    /// The material table (block in scene.glsl).
    buffer_reference MaterialsRef;
    /// The light table (block in scene.glsl).
    buffer_reference LightsRef;
    /// The lighting record (block in scene.glsl).
    buffer_reference LightingRef;

    /// Push constants shared by every pass: addresses, and values that change per pass or only
    /// with a setting. No count that bounds a loop lives here: Mesa's lavapipe (the CPU device
    /// the tests run on) inlines the push-constant values that a shader's branches and loop
    /// bounds test (`lvp_inline_uniforms.c`) and compiles a variant for each new set of values,
    /// its loops unrolled to the count; the lights' high-water mark, which changes whenever a
    /// game spawns a light, is `GpuLighting::light_count` instead.
    #[layout(push_constant, instance = scene)]
    #[derive(Default)]
    pub struct ScenePush {
        /// Address of the camera record.
        pub camera: u64 as CameraRef,
        /// Address of the instance table.
        pub instances: u64 as InstancesRef,
        /// Address of the material table.
        pub materials: u64 as MaterialsRef,
        /// Address of the light table.
        pub lights: u64 as LightsRef,
        /// Address of the decal table (`DecalsRef`, decals.glsl).
        pub decals: u64,
        /// Address of the decal material table (`DecalMaterialsRef`).
        pub decal_materials: u64,
        /// Address of the decal TLAS (0: no decals).
        pub decal_tlas: u64,
        /// Address of the decal boxes the decal BLAS is built from.
        pub decal_aabbs: u64,
        /// Address of the mesh table (`MeshesRef`: vertex and index addresses per mesh).
        pub meshes: u64,
        /// Address of the deferred decals' draw order (live slots sorted by channel, then weight).
        pub decal_order: u64,
        /// Padding.
        pub pad: u32,
        /// A full-screen pass's input image (bindless slot); in the shadow-map pass, the view
        /// being drawn.
        pub texture_index: u32,
        /// Debug visualisation selector (a `DEBUG_*` value).
        pub debug_view: u32,
        /// Live decals (0 skips the decal loop).
        pub decal_count: u32,
        /// Address of the decal list buffer: the cluster buffer with clustered decals
        /// (`shaders/include/clusters.glsl`), the per-pixel lists with the ray-tracing-pipeline
        /// decal pass (`shaders/include/decal_lists.glsl`); 0 with neither.
        pub decal_lists: u64,
        /// Entries the decal list buffer has room for.
        pub decal_list_capacity: u32,
        /// Screen tiles of the decal clusters: x in the low 16 bits, y in the high.
        pub decal_cluster_tiles: u32,
        /// Address of the lighting record.
        pub lighting: u64 as LightingRef,
        /// Address of the shadow maps' views buffer: a header (`SHADOW_VIEWS_HEADER` words: the
        /// word offset of the views, their count), each light slot's first view
        /// (`NO_SHADOW_MAP`: none), then the `GpuShadowView`s (`shaders/include/shadow_maps.glsl`).
        pub shadow_views: u64,
    }
}

const _: () = assert!(std::mem::size_of::<GpuVertex>() == VERTEX_BYTES as usize, "VERTEX_BYTES is a GpuVertex's size");
const _: () = assert!(std::mem::size_of::<ScenePush>() <= 128, "push constants within the 128 bytes every device offers");

const _: () = {
    let slots = [TEXTURE_WHITE, TEXTURE_FLAT_NORMAL, TEXTURE_LTC];
    let mut i = 0;
    while i < slots.len() {
        assert!(slots[i] < RESERVED_TEXTURES, "built-in bindless slots must be below RESERVED_TEXTURES");
        i += 1;
    }
};

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn shaders_were_built_from_this_description() {
        assert_eq!(glsl(), include_str!(concat!(env!("OUT_DIR"), "/layout.glsl")));
    }

    #[test]
    fn offsets_follow_the_glsl_rules() {
        // vec3 + float share 16 bytes; a vec3 after a float starts at the next 16 under std430,
        // right after it under scalar; uint arrays align to 4.
        let offsets = |s: &Struct| s.fields.iter().map(|f| f.offset).collect::<Vec<_>>();
        assert_eq!(offsets(&GpuLight::LAYOUT), [0, 12, 16, 28, 32, 44, 48, 52, 56, 60]);
        assert_eq!(GpuLight::LAYOUT.size, 64);
        assert_eq!(offsets(&GpuVertex::LAYOUT), [0, 12, 16, 20]);
        assert_eq!(GpuVertex::LAYOUT.size, VERTEX_BYTES as usize);
        assert_eq!(offsets(&GpuMaterial::LAYOUT)[..3], [0, 16, 28]);
        assert_eq!(offsets(&ScenePush::LAYOUT)[10..], [80, 84, 88, 92, 96, 104, 108, 112, 120]);
    }
}
