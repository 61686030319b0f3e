//! Per-vertex attribute streams besides the position: normals, tangents, UV sets,
//! colours, joints and weights, morph-target deltas, and attributes rtmesh does not
//! know (glTF `_CUSTOM`, extra PLY properties), each kept as the typed values the file
//! stored so that what is written back is bit for bit what was read.
//!
//! Operations that move vertices gather streams ([`VertexAttribute::gather`]); the one
//! that makes vertices (edge bisection) interpolates them
//! ([`VertexAttribute::push_midpoint`]): floats and normalized integers at the
//! midpoint, normals and tangents renormalized, joints, weights and plain integers
//! copied from the first end (a joint set is meaningless halfway, and a vertex's joints
//! and weights must come from the same vertex). Cost O(vertices × components).

use glam::{Mat3, Vec3};

/// The values of one attribute, `components` per vertex, vertex after vertex, in the
/// type the file stored them in.
#[derive(Clone, Debug, PartialEq)]
pub enum AttributeValues {
    /// Unsigned 8-bit.
    U8(Vec<u8>),
    /// Signed 8-bit.
    I8(Vec<i8>),
    /// Unsigned 16-bit.
    U16(Vec<u16>),
    /// Signed 16-bit.
    I16(Vec<i16>),
    /// Unsigned 32-bit.
    U32(Vec<u32>),
    /// Signed 32-bit.
    I32(Vec<i32>),
    /// 32-bit float.
    F32(Vec<f32>),
    /// 64-bit float (PLY `double`).
    F64(Vec<f64>),
}

/// Runs `$body` with `$v` bound to the typed vector inside `$values`.
macro_rules! each_type {
    ($values:expr, $v:ident => $body:expr) => {
        match $values {
            AttributeValues::U8($v) => $body,
            AttributeValues::I8($v) => $body,
            AttributeValues::U16($v) => $body,
            AttributeValues::I16($v) => $body,
            AttributeValues::U32($v) => $body,
            AttributeValues::I32($v) => $body,
            AttributeValues::F32($v) => $body,
            AttributeValues::F64($v) => $body,
        }
    };
}

/// The same variant as `$values`, holding `$body` computed with `$v` bound to the typed
/// vector inside.
macro_rules! map_type {
    ($values:expr, $v:ident => $body:expr) => {
        match $values {
            AttributeValues::U8($v) => AttributeValues::U8($body),
            AttributeValues::I8($v) => AttributeValues::I8($body),
            AttributeValues::U16($v) => AttributeValues::U16($body),
            AttributeValues::I16($v) => AttributeValues::I16($body),
            AttributeValues::U32($v) => AttributeValues::U32($body),
            AttributeValues::I32($v) => AttributeValues::I32($body),
            AttributeValues::F32($v) => AttributeValues::F32($body),
            AttributeValues::F64($v) => AttributeValues::F64($body),
        }
    };
}

/// A scalar type an attribute can hold, converted through f64 (exact for all of them).
trait Scalar: Copy + Default {
    /// True for f32 and f64.
    const FLOAT: bool;
    fn to_f64(self) -> f64;
    /// Rounded to the nearest for integer types.
    fn from_f64(x: f64) -> Self;
    /// Little-endian bytes, for hashing vertices.
    fn push_bytes(self, out: &mut Vec<u8>);
}

macro_rules! scalar {
    ($t:ty, $float:expr) => {
        impl Scalar for $t {
            const FLOAT: bool = $float;
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn from_f64(x: f64) -> Self {
                if $float {
                    x as $t
                } else {
                    x.round() as $t
                }
            }
            #[inline]
            fn push_bytes(self, out: &mut Vec<u8>) {
                out.extend_from_slice(&self.to_le_bytes());
            }
        }
    };
}
scalar!(u8, false);
scalar!(i8, false);
scalar!(u16, false);
scalar!(i16, false);
scalar!(u32, false);
scalar!(i32, false);
scalar!(f32, true);
scalar!(f64, true);

/// What an attribute means, which decides how a new vertex gets its value and how a
/// transform applies. Read from the glTF-style name.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Semantic {
    /// `NORMAL`: unit vectors, renormalized when interpolated, turned by the inverse
    /// transpose when a transform is baked in.
    Normal,
    /// `TANGENT`: xyz like a normal, w (the handedness) copied.
    Tangent,
    /// `TEXCOORD_n`.
    TexCoord,
    /// `COLOR_n`.
    Color,
    /// `JOINTS_n`: copied, never interpolated.
    Joints,
    /// `WEIGHTS_n`: copied with the joints.
    Weights,
    /// A morph target's delta (`target<k>:<NAME>`): interpolated, never renormalized.
    MorphDelta,
    /// Anything else (`_CUSTOM`, PLY properties): floats interpolated, integers copied.
    Custom,
}

impl Semantic {
    /// The semantic of an attribute called `name`.
    pub fn of(name: &str) -> Self {
        if name.starts_with(MORPH_PREFIX) {
            return Self::MorphDelta;
        }
        let base = name.split('_').next().unwrap_or(name);
        match base {
            "NORMAL" => Self::Normal,
            "TANGENT" => Self::Tangent,
            "TEXCOORD" => Self::TexCoord,
            "COLOR" => Self::Color,
            "JOINTS" => Self::Joints,
            "WEIGHTS" => Self::Weights,
            _ => Self::Custom,
        }
    }
}

/// Morph-target deltas are named `target<k>:<ATTRIBUTE>` (`target0:POSITION`).
pub const MORPH_PREFIX: &str = "target";

/// The name of morph target `k`'s delta of `attribute`.
pub fn morph_name(k: usize, attribute: &str) -> String {
    format!("{MORPH_PREFIX}{k}:{attribute}")
}

/// One per-vertex attribute stream.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexAttribute {
    /// glTF attribute name: `NORMAL`, `TANGENT`, `TEXCOORD_0`, `COLOR_0`, `JOINTS_0`,
    /// `WEIGHTS_0`, `_CUSTOM`, or `target<k>:<NAME>` for morph target deltas; PLY
    /// properties rtmesh does not know keep their own name.
    pub name: String,
    /// Values per vertex (1 to 4, or 16 for a matrix).
    pub components: usize,
    /// Integer values stand for [0, 1] (unsigned) or [−1, 1] (signed), as glTF's
    /// `normalized`.
    pub normalized: bool,
    /// The values, `components` per vertex.
    pub values: AttributeValues,
    /// The source's names of the components, where it has them (PLY `nx ny nz`), so
    /// that a writer of the same format writes them back; empty otherwise.
    pub component_names: Vec<String>,
}

impl VertexAttribute {
    /// An f32 attribute from per-vertex arrays.
    pub fn from_f32<const N: usize>(name: &str, values: &[[f32; N]]) -> Self {
        Self {
            name: name.to_owned(),
            components: N,
            normalized: false,
            values: AttributeValues::F32(values.iter().flatten().copied().collect()),
            component_names: Vec::new(),
        }
    }

    /// What the attribute means.
    pub fn semantic(&self) -> Semantic {
        Semantic::of(&self.name)
    }

    /// Number of vertices it holds values for.
    pub fn vertex_count(&self) -> usize {
        each_type!(&self.values, v => v.len()) / self.components.max(1)
    }

    /// Component `c` of vertex `v`, as f64 (exact for every stored type).
    pub fn get(&self, v: usize, c: usize) -> f64 {
        let i = v * self.components + c;
        each_type!(&self.values, values => values[i].to_f64())
    }

    /// The components of vertex `v` as f64.
    pub fn vertex(&self, v: usize) -> Vec<f64> {
        (0..self.components).map(|c| self.get(v, c)).collect()
    }

    /// The component type's name, as PLY spells it (`uchar`, `float`, ...).
    pub fn type_name(&self) -> &'static str {
        match &self.values {
            AttributeValues::U8(_) => "uchar",
            AttributeValues::I8(_) => "char",
            AttributeValues::U16(_) => "ushort",
            AttributeValues::I16(_) => "short",
            AttributeValues::U32(_) => "uint",
            AttributeValues::I32(_) => "int",
            AttributeValues::F32(_) => "float",
            AttributeValues::F64(_) => "double",
        }
    }

    /// The same attribute with vertex `i` taken from vertex `sources[i]`.
    pub fn gather(&self, sources: &[u32]) -> Self {
        let k = self.components;
        let values = map_type!(&self.values, values => {
            let mut out = Vec::with_capacity(sources.len() * k);
            for &s in sources {
                let s = s as usize * k;
                out.extend_from_slice(&values[s..s + k]);
            }
            out
        });
        Self {
            name: self.name.clone(),
            components: self.components,
            normalized: self.normalized,
            values,
            component_names: self.component_names.clone(),
        }
    }

    /// The same attribute (name, type, flags) with no vertices.
    pub fn emptied(&self) -> Self {
        self.gather(&[])
    }

    /// Append a copy of vertex `v`'s values.
    pub fn push_copy(&mut self, v: usize) {
        let k = self.components;
        each_type!(&mut self.values, values => values.extend_from_within(v * k..v * k + k))
    }

    /// Append vertex `v` of `from` (an attribute of the same name and type).
    pub fn append_vertex_of(&mut self, from: &VertexAttribute, v: usize) {
        let k = self.components;
        macro_rules! same {
            ($($variant:ident),*) => {
                match (&mut self.values, &from.values) {
                    $((AttributeValues::$variant(out), AttributeValues::$variant(src)) => {
                        out.extend_from_slice(&src[v * k..v * k + k])
                    })*
                    (out, _) => each_type!(out, values => {
                        for c in 0..k {
                            values.push(Scalar::from_f64(from.get(v, c)));
                        }
                    }),
                }
            };
        }
        same!(U8, I8, U16, I16, U32, I32, F32, F64)
    }

    /// Append `count` vertices of zeros (for vertices whose source had no such
    /// attribute).
    pub fn push_zeros(&mut self, count: usize) {
        let n = count * self.components;
        each_type!(&mut self.values, values => values.resize(values.len() + n, Default::default()))
    }

    /// Append the value of a new vertex halfway along the edge from vertex `a` to `b`
    /// (see the module doc for the rule per semantic).
    pub fn push_midpoint(&mut self, a: usize, b: usize) {
        let semantic = self.semantic();
        let normalized = self.normalized;
        let k = self.components;
        fn midpoint<T: Scalar>(
            values: &mut Vec<T>,
            k: usize,
            a: usize,
            b: usize,
            unit: Option<usize>,
            blend: bool,
        ) {
            if !blend {
                values.extend_from_within(a * k..a * k + k);
                return;
            }
            let mut mid: Vec<f64> = (0..k)
                .map(|c| 0.5 * (values[a * k + c].to_f64() + values[b * k + c].to_f64()))
                .collect();
            if let Some(n) = unit {
                let length = mid[..n].iter().map(|x| x * x).sum::<f64>().sqrt();
                if length > 0.0 {
                    mid[..n].iter_mut().for_each(|x| *x /= length);
                }
                // A tangent's w is its handedness: the first end's.
                for (c, x) in mid.iter_mut().enumerate().skip(n) {
                    *x = values[a * k + c].to_f64();
                }
            }
            values.extend(mid.into_iter().map(T::from_f64));
        }
        let unit = match semantic {
            Semantic::Normal => Some(k.min(3)),
            Semantic::Tangent => Some(3.min(k)),
            _ => None,
        };
        each_type!(&mut self.values, values => {
            let blend = match semantic {
                Semantic::Joints | Semantic::Weights => false,
                _ => is_float(values) || normalized,
            };
            midpoint(values, k, a, b, unit, blend)
        })
    }

    /// Append every vertex of `other`, converted to this attribute's type where the two
    /// differ.
    pub fn append(&mut self, other: &VertexAttribute) {
        let k = self.components;
        let n = other.vertex_count();
        each_type!(&mut self.values, values => {
            values.reserve(n * k);
            for v in 0..n {
                for c in 0..k {
                    let x = if c < other.components { other.get(v, c) } else { 0.0 };
                    values.push(Scalar::from_f64(x));
                }
            }
        })
    }

    /// Bake `linear` (the linear part of an object-to-world transform) into normals
    /// and tangents: normals by its inverse transpose, tangents by itself, both
    /// renormalized. Other semantics are left alone. Only f32 streams are turned.
    pub fn transform(&mut self, linear: Mat3) {
        let matrix = match self.semantic() {
            Semantic::Normal => linear.inverse().transpose(),
            Semantic::Tangent => linear,
            _ => return,
        };
        if matrix == Mat3::IDENTITY || self.components < 3 {
            return;
        }
        let k = self.components;
        if let AttributeValues::F32(values) = &mut self.values {
            for vertex in values.chunks_exact_mut(k) {
                let turned =
                    (matrix * Vec3::new(vertex[0], vertex[1], vertex[2])).normalize_or_zero();
                vertex[..3].copy_from_slice(&turned.to_array());
            }
        }
    }

    /// Append vertex `v`'s bytes (for hashing whole vertices when welding).
    pub(crate) fn push_vertex_bytes(&self, v: usize, out: &mut Vec<u8>) {
        let k = self.components;
        each_type!(&self.values, values => {
            for &x in &values[v * k..v * k + k] {
                x.push_bytes(out);
            }
        })
    }
}

fn is_float<T: Scalar>(_: &[T]) -> bool {
    T::FLOAT
}

/// The streams of `attributes` gathered by `sources` (new vertex `i` is old vertex
/// `sources[i]`).
pub(crate) fn gather_all(attributes: &[VertexAttribute], sources: &[u32]) -> Vec<VertexAttribute> {
    attributes.iter().map(|a| a.gather(sources)).collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn midpoints_follow_the_semantic() {
        let mut uv = VertexAttribute::from_f32("TEXCOORD_0", &[[0.0, 0.0], [1.0, 0.5]]);
        uv.push_midpoint(0, 1);
        assert_eq!(uv.vertex(2), vec![0.5, 0.25]);
        let mut normal = VertexAttribute::from_f32("NORMAL", &[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        normal.push_midpoint(0, 1);
        let h = std::f32::consts::FRAC_1_SQRT_2 as f64;
        assert!((normal.get(2, 0) - h).abs() < 1e-6 && (normal.get(2, 1) - h).abs() < 1e-6);
        let mut joints = VertexAttribute {
            name: "JOINTS_0".into(),
            components: 4,
            normalized: false,
            values: AttributeValues::U8(vec![1, 2, 3, 4, 5, 6, 7, 8]),
            component_names: Vec::new(),
        };
        joints.push_midpoint(1, 0);
        assert_eq!(joints.vertex(2), vec![5.0, 6.0, 7.0, 8.0]);
        let mut color = VertexAttribute {
            name: "COLOR_0".into(),
            components: 1,
            normalized: true,
            values: AttributeValues::U8(vec![0, 255]),
            component_names: Vec::new(),
        };
        color.push_midpoint(0, 1);
        assert_eq!(color.vertex(2), vec![128.0]);
    }

    #[test]
    fn gather_and_append_keep_values() {
        let a = VertexAttribute::from_f32("NORMAL", &[[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]]);
        let g = a.gather(&[1, 1, 0]);
        assert_eq!(g.vertex_count(), 3);
        assert_eq!(g.vertex(0), vec![0.0, 1.0, 0.0]);
        let mut b = g.clone();
        b.append(&a);
        assert_eq!(b.vertex_count(), 5);
        assert_eq!(b.vertex(4), vec![0.0, 1.0, 0.0]);
        b.push_zeros(1);
        assert_eq!(b.vertex(5), vec![0.0; 3]);
    }

    #[test]
    fn semantics_from_names() {
        assert_eq!(Semantic::of("TEXCOORD_1"), Semantic::TexCoord);
        assert_eq!(Semantic::of(&morph_name(2, "NORMAL")), Semantic::MorphDelta);
        assert_eq!(Semantic::of("_TEMPERATURE"), Semantic::Custom);
        assert_eq!(Semantic::of("NORMAL"), Semantic::Normal);
    }
}
