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
    /// The stored value that stands for 1 when the stream is normalized (the type's
    /// largest; 1 for floats), as glTF's `normalized` reads integers.
    const UNIT: f64;
    fn to_f64(self) -> f64;
    /// Rounded to the nearest for integer types.
    fn from_f64(x: f64) -> Self;
    /// Little-endian bytes, for hashing vertices.
    fn push_bytes(self, out: &mut Vec<u8>);
}

macro_rules! scalar {
    ($t:ty, $float:expr, $unit:expr) => {
        impl Scalar for $t {
            const FLOAT: bool = $float;
            const UNIT: f64 = $unit;
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
scalar!(u8, false, u8::MAX as f64);
scalar!(i8, false, i8::MAX as f64);
scalar!(u16, false, u16::MAX as f64);
scalar!(i16, false, i16::MAX as f64);
scalar!(u32, false, u32::MAX as f64);
scalar!(i32, false, i32::MAX as f64);
scalar!(f32, true, 1.0);
scalar!(f64, true, 1.0);

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

    /// Component `c` of vertex `v` as the number it stands for: a normalized integer
    /// mapped to [0, 1] or [−1, 1] by glTF's rule (`max(c / MAX, −1)`), anything else
    /// as stored.
    pub fn value(&self, v: usize, c: usize) -> f64 {
        let i = v * self.components + c;
        let normalized = self.normalized;
        each_type!(&self.values, values => unit_value(values[i], normalized))
    }

    /// The attribute with normalized integers replaced by the f32 numbers they stand
    /// for ([`VertexAttribute::value`]), for formats that hold no `normalized` flag;
    /// borrowed when there is nothing to convert.
    pub fn dequantized(&self) -> std::borrow::Cow<'_, VertexAttribute> {
        match self.normalized && !matches!(self.values, AttributeValues::F32(_)) {
            true => std::borrow::Cow::Owned(self.to_f32()),
            false => std::borrow::Cow::Borrowed(self),
        }
    }

    /// The attribute as f32 numbers, each the number its stored value stands for
    /// ([`VertexAttribute::value`]).
    pub fn to_f32(&self) -> VertexAttribute {
        let k = self.components;
        let values = (0..self.vertex_count() * k).map(|i| self.value(i / k, i % k) as f32);
        VertexAttribute {
            normalized: false,
            values: AttributeValues::F32(values.collect()),
            ..self.emptied()
        }
    }

    /// The attribute in `like`'s stored type and `normalized` flag (its values are not
    /// used), if every value comes back exactly as the f32 number it is here: how a
    /// stream read quantized and dequantized (glTF's `KHR_mesh_quantization`) is written
    /// back in its own type. `None` when some value is not held exactly there.
    pub fn stored_as(&self, like: &VertexAttribute) -> Option<VertexAttribute> {
        fn requantize<T: Scalar>(
            _: &[T],
            from: &VertexAttribute,
            normalized: bool,
        ) -> (Vec<T>, bool) {
            let k = from.components;
            let mut exact = true;
            let scale = if normalized { T::UNIT } else { 1.0 };
            let values = (0..from.vertex_count() * k)
                .map(|i| {
                    let x = from.value(i / k, i % k) as f32;
                    let stored = T::from_f64(x as f64 * scale);
                    exact &= unit_value(stored, normalized) as f32 == x;
                    stored
                })
                .collect();
            (values, exact)
        }
        let mut exact = true;
        let values = map_type!(&like.values, kind => {
            let (values, held) = requantize(kind, self, like.normalized);
            exact &= held;
            values
        });
        exact.then(|| VertexAttribute {
            normalized: like.normalized,
            values,
            ..self.emptied()
        })
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
                // A normalized integer's unit vector has length T::UNIT as stored.
                let length = mid[..n].iter().map(|x| x * x).sum::<f64>().sqrt() / T::UNIT;
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
    /// renormalized. Other semantics are left alone. Float and normalized integer
    /// streams are turned (integers rounded back to their type); plain integers, which
    /// stand for no direction, are not.
    pub fn transform(&mut self, linear: Mat3) {
        let matrix = match self.semantic() {
            Semantic::Normal => linear.inverse().transpose(),
            Semantic::Tangent => linear,
            _ => return,
        };
        self.turn_each(|_| matrix);
    }

    /// [`transform`](Self::transform) with a linear map J of its own for each vertex
    /// (a deformation's Jacobian). Normals go by J's cofactor matrix, det J · J⁻ᵀ,
    /// which is what the triangles' own normals follow: where a deformation folds
    /// space (det J < 0) the normals keep to the side the triangles' winding faces.
    /// Vertices whose map is the identity keep their stored values bit for bit.
    pub fn transform_each(&mut self, linear: impl Fn(usize) -> Mat3) {
        let cofactor = |j: Mat3| {
            Mat3::from_cols(
                j.y_axis.cross(j.z_axis),
                j.z_axis.cross(j.x_axis),
                j.x_axis.cross(j.y_axis),
            )
        };
        match self.semantic() {
            Semantic::Normal => self.turn_each(|v| cofactor(linear(v))),
            Semantic::Tangent => self.turn_each(linear),
            _ => {}
        }
    }

    /// Each vertex's first three components turned by `matrix_of` it and renormalized.
    fn turn_each(&mut self, matrix_of: impl Fn(usize) -> Mat3) {
        if self.components < 3 {
            return;
        }
        fn turn<T: Scalar>(
            values: &mut [T],
            k: usize,
            matrix_of: &dyn Fn(usize) -> Mat3,
            normalized: bool,
        ) {
            if !T::FLOAT && !normalized {
                return;
            }
            for (v, vertex) in values.chunks_exact_mut(k).enumerate() {
                let matrix = matrix_of(v);
                if matrix == Mat3::IDENTITY {
                    continue;
                }
                let [x, y, z] = [0, 1, 2].map(|c| unit_value(vertex[c], normalized) as f32);
                let turned = (matrix * Vec3::new(x, y, z)).normalize_or_zero();
                for (stored, t) in vertex.iter_mut().zip(turned.to_array()) {
                    *stored = T::from_f64(t as f64 * T::UNIT);
                }
            }
        }
        let (k, normalized) = (self.components, self.normalized);
        each_type!(&mut self.values, values => turn(values, k, &matrix_of, normalized))
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

/// The number `x` stands for (see [`VertexAttribute::value`]).
fn unit_value<T: Scalar>(x: T, normalized: bool) -> f64 {
    match normalized && !T::FLOAT {
        true => (x.to_f64() / T::UNIT).max(-1.0),
        false => x.to_f64(),
    }
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

    fn normal_i8(values: Vec<i8>) -> VertexAttribute {
        VertexAttribute {
            name: "NORMAL".into(),
            components: 3,
            normalized: true,
            values: AttributeValues::I8(values),
            component_names: Vec::new(),
        }
    }

    #[test]
    fn normalized_integers_stand_for_numbers_by_gltfs_rule() {
        let normal = normal_i8(vec![127, 0, -128, 0, 90, 90]);
        // max(c / 127, −1): −128 stands for −1 as −127 does.
        assert_eq!(normal.vertex(0), vec![127.0, 0.0, -128.0]);
        assert_eq!(normal.value(0, 0), 1.0);
        assert_eq!(normal.value(0, 2), -1.0);
        assert_eq!(normal.value(1, 1), 90.0 / 127.0);
        let AttributeValues::F32(numbers) = normal.dequantized().into_owned().values else {
            panic!("dequantized to f32")
        };
        assert_eq!(
            numbers,
            [1.0, 0.0, -1.0, 0.0, 90.0 / 127.0, 90.0 / 127.0].map(|x| x as f32)
        );
        // Plain integers and floats are the numbers they are.
        let uv = VertexAttribute {
            normalized: false,
            ..normal_i8(vec![5, 6, 7])
        };
        assert!(matches!(uv.dequantized(), std::borrow::Cow::Borrowed(_)));
        assert_eq!(uv.to_f32().vertex(0), vec![5.0, 6.0, 7.0]);
    }

    #[test]
    fn numbers_go_back_to_their_stored_type_only_when_exact() {
        let stored = normal_i8(vec![127, 0, -127, 0, 90, 90]);
        let numbers = stored.to_f32();
        let back = numbers.stored_as(&stored.emptied()).expect("held exactly");
        assert_eq!(back, stored);
        let mut moved = numbers.clone();
        if let AttributeValues::F32(v) = &mut moved.values {
            v[4] = 0.5;
        }
        assert_eq!(moved.stored_as(&stored.emptied()), None);
        // Unnormalized u16 positions: integers only, within range.
        let like = VertexAttribute {
            name: "POSITION".into(),
            components: 3,
            normalized: false,
            values: AttributeValues::U16(Vec::new()),
            component_names: Vec::new(),
        };
        let whole = VertexAttribute::from_f32("POSITION", &[[0.0, 1000.0, 65535.0]]);
        assert_eq!(
            whole.stored_as(&like).unwrap().values,
            AttributeValues::U16(vec![0, 1000, 65535])
        );
        for bad in [
            [0.5, 0.0, 0.0],
            [-1.0, 0.0, 0.0],
            [65536.0, 0.0, 0.0],
            [f32::NAN, 0.0, 0.0],
        ] {
            assert_eq!(
                VertexAttribute::from_f32("POSITION", &[bad]).stored_as(&like),
                None,
                "{bad:?}"
            );
        }
    }

    #[test]
    fn normalized_normals_are_turned_and_interpolated_as_unit_vectors() {
        let mut normal = normal_i8(vec![127, 0, 0, 0, 127, 0]);
        normal.push_midpoint(0, 1);
        // Halfway: (1, 1, 0) / √2, stored as 127 / √2 ≈ 89.8 → 90.
        assert_eq!(normal.vertex(2), vec![90.0, 90.0, 0.0]);
        normal.transform(Mat3::from_rotation_z(std::f32::consts::FRAC_PI_2));
        assert_eq!(normal.vertex(0), vec![0.0, 127.0, 0.0]);
        assert_eq!(normal.vertex(1), vec![-127.0, 0.0, 0.0]);
        // Plain integers stand for no direction and are left alone.
        let mut plain = VertexAttribute {
            normalized: false,
            ..normal_i8(vec![1, 0, 0])
        };
        plain.transform(Mat3::from_rotation_z(std::f32::consts::FRAC_PI_2));
        assert_eq!(plain.vertex(0), vec![1.0, 0.0, 0.0]);
    }

    #[test]
    fn semantics_from_names() {
        assert_eq!(Semantic::of("TEXCOORD_1"), Semantic::TexCoord);
        assert_eq!(Semantic::of(&morph_name(2, "NORMAL")), Semantic::MorphDelta);
        assert_eq!(Semantic::of("_TEMPERATURE"), Semantic::Custom);
        assert_eq!(Semantic::of("NORMAL"), Semantic::Normal);
    }
}
