//! Cell data types and the [`Cell`] trait that converts between them.

use serde::{Deserialize, Serialize};

/// The data type of a raster's cells, as stored on disk.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum DType {
    U8,
    I8,
    U16,
    I16,
    U32,
    I32,
    F32,
    F64,
}

/// What a raster's values are, for consumers that treat them differently
/// (overview resampling, correlation tables, colour maps): a step declares
/// it per output (`exec::output::OutputSpec`), the metric registry
/// per metric, a tile store's provenance records it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum OutputKind {
    /// A quantity on a linear scale (elevations, slopes, areas).
    #[default]
    Continuous,
    /// Class codes (D8 directions, labels, landforms, patterns): no value
    /// between two codes means anything.
    Categorical,
    /// A circular quantity that wraps at 360° (aspect).
    Angle,
}

impl OutputKind {
    /// True for [`OutputKind::Continuous`] (a store's provenance omits it).
    pub fn is_continuous(&self) -> bool {
        *self == OutputKind::Continuous
    }
}

impl DType {
    /// Every type, in declaration order: integers by width (unsigned before
    /// signed), then floats by width. The order is the MPI wire code of a
    /// type (`exec::mpi_codec`) and the mosaic's narrowest-first search:
    /// never reorder.
    pub const ALL: [DType; 8] = [
        DType::U8,
        DType::I8,
        DType::U16,
        DType::I16,
        DType::U32,
        DType::I32,
        DType::F32,
        DType::F64,
    ];

    /// Bytes per cell.
    pub fn size(self) -> usize {
        match self {
            DType::U8 | DType::I8 => 1,
            DType::U16 | DType::I16 => 2,
            DType::U32 | DType::I32 | DType::F32 => 4,
            DType::F64 => 8,
        }
    }
    /// True for f32 and f64.
    pub fn is_float(self) -> bool {
        matches!(self, DType::F32 | DType::F64)
    }
    /// Lower-case name (`"int16"` style names are GDAL's; these are Rust's).
    pub fn name(self) -> &'static str {
        match self {
            DType::U8 => "u8",
            DType::I8 => "i8",
            DType::U16 => "u16",
            DType::I16 => "i16",
            DType::U32 => "u32",
            DType::I32 => "i32",
            DType::F32 => "f32",
            DType::F64 => "f64",
        }
    }
    /// Parse a dtype name (Rust or GDAL spelling).
    pub fn parse(s: &str) -> Option<DType> {
        Some(match s.to_ascii_lowercase().as_str() {
            "u8" | "byte" | "uint8" => DType::U8,
            "i8" | "int8" => DType::I8,
            "u16" | "uint16" => DType::U16,
            "i16" | "int16" => DType::I16,
            "u32" | "uint32" => DType::U32,
            "i32" | "int32" => DType::I32,
            "f32" | "float32" => DType::F32,
            "f64" | "float64" => DType::F64,
            _ => return None,
        })
    }
    /// Whether `v` is exactly representable in this type (used to validate nodata).
    pub fn represents(self, v: f64) -> bool {
        match self {
            DType::F64 => true,
            DType::F32 => v.is_nan() || (v as f32) as f64 == v || v.is_infinite(),
            _ => {
                let (lo, hi) = self.int_range();
                v.fract() == 0.0 && v >= lo && v <= hi
            }
        }
    }
    /// Range of an integer type as f64 (floats: ±f64::MAX).
    pub fn int_range(self) -> (f64, f64) {
        match self {
            DType::U8 => (0.0, u8::MAX as f64),
            DType::I8 => (i8::MIN as f64, i8::MAX as f64),
            DType::U16 => (0.0, u16::MAX as f64),
            DType::I16 => (i16::MIN as f64, i16::MAX as f64),
            DType::U32 => (0.0, u32::MAX as f64),
            DType::I32 => (i32::MIN as f64, i32::MAX as f64),
            DType::F32 | DType::F64 => (-f64::MAX, f64::MAX),
        }
    }
}

impl std::fmt::Display for DType {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// A cell value type. Conversions go through f64, which represents every
/// value of every supported type exactly.
pub trait Cell:
    Copy + Default + PartialOrd + PartialEq + Send + Sync + std::fmt::Debug + bytemuck::Pod + 'static
{
    /// The matching [`DType`].
    const DTYPE: DType;
    /// Exact widening to f64.
    fn to_f64(self) -> f64;
    /// Conversion from f64: floats round to nearest, integers round half away
    /// from zero and saturate; NaN becomes 0 for integers.
    fn from_f64(v: f64) -> Self;
    /// True if the value is NaN (always false for integers).
    fn is_nan(self) -> bool {
        false
    }
}

macro_rules! int_cell {
    ($t:ty, $d:ident) => {
        impl Cell for $t {
            const DTYPE: DType = DType::$d;
            #[inline]
            fn to_f64(self) -> f64 {
                self as f64
            }
            #[inline]
            fn from_f64(v: f64) -> Self {
                // `as` saturates and maps NaN to 0.
                v.round() as $t
            }
        }
    };
}
int_cell!(u8, U8);
int_cell!(i8, I8);
int_cell!(u16, U16);
int_cell!(i16, I16);
int_cell!(u32, U32);
int_cell!(i32, I32);

impl Cell for f32 {
    const DTYPE: DType = DType::F32;
    #[inline]
    fn to_f64(self) -> f64 {
        self as f64
    }
    #[inline]
    fn from_f64(v: f64) -> Self {
        v as f32
    }
    #[inline]
    fn is_nan(self) -> bool {
        f32::is_nan(self)
    }
}

impl Cell for f64 {
    const DTYPE: DType = DType::F64;
    #[inline]
    fn to_f64(self) -> f64 {
        self
    }
    #[inline]
    fn from_f64(v: f64) -> Self {
        v
    }
    #[inline]
    fn is_nan(self) -> bool {
        f64::is_nan(self)
    }
}
