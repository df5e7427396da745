//! `Grid<T>`: a dense row-major 2-D array, the in-memory raster of orogen.

use super::dtype::{Cell, DType};
use super::window::Window;
use crate::error::{Error, Result};

/// A dense row-major grid of `width` x `height` cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid<T> {
    width: usize,
    height: usize,
    data: Vec<T>,
}

impl<T: Copy> Grid<T> {
    /// A grid filled with `v`.
    pub fn new(width: usize, height: usize, v: T) -> Self {
        Grid {
            width,
            height,
            data: vec![v; width * height],
        }
    }
    /// Wrap a vector (must hold `width * height` cells).
    pub fn from_vec(width: usize, height: usize, data: Vec<T>) -> Result<Self> {
        if data.len() != width * height {
            return Err(Error::invalid(format!(
                "grid of {width}x{height} needs {} cells, got {}",
                width * height,
                data.len()
            )));
        }
        Ok(Grid {
            width,
            height,
            data,
        })
    }
    /// Build from a function of (column, row).
    pub fn from_fn(width: usize, height: usize, mut f: impl FnMut(usize, usize) -> T) -> Self {
        let mut data = Vec::with_capacity(width * height);
        for y in 0..height {
            for x in 0..width {
                data.push(f(x, y));
            }
        }
        Grid {
            width,
            height,
            data,
        }
    }
    /// Columns.
    #[inline]
    pub fn width(&self) -> usize {
        self.width
    }
    /// Rows.
    #[inline]
    pub fn height(&self) -> usize {
        self.height
    }
    /// Cell count.
    #[inline]
    pub fn len(&self) -> usize {
        self.data.len()
    }
    /// True when the grid has no cells.
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.data.is_empty()
    }
    /// Flat index of (x, y).
    #[inline]
    pub fn idx(&self, x: usize, y: usize) -> usize {
        y * self.width + x
    }
    /// Value at (x, y). Panics out of bounds (internal use with checked indices).
    #[inline]
    pub fn get(&self, x: usize, y: usize) -> T {
        self.data[y * self.width + x]
    }
    /// Set (x, y).
    #[inline]
    pub fn set(&mut self, x: usize, y: usize, v: T) {
        self.data[y * self.width + x] = v;
    }
    /// Flat data.
    #[inline]
    pub fn data(&self) -> &[T] {
        &self.data
    }
    /// Flat data, mutable.
    #[inline]
    pub fn data_mut(&mut self) -> &mut [T] {
        &mut self.data
    }
    /// Consume into the flat vector.
    pub fn into_vec(self) -> Vec<T> {
        self.data
    }
    /// Row `y`.
    #[inline]
    pub fn row(&self, y: usize) -> &[T] {
        &self.data[y * self.width..(y + 1) * self.width]
    }
    /// Row `y`, mutable.
    #[inline]
    pub fn row_mut(&mut self, y: usize) -> &mut [T] {
        &mut self.data[y * self.width..(y + 1) * self.width]
    }
    /// Copy of the sub-rectangle `win` (local coordinates; must lie inside).
    pub fn crop(&self, win: Window) -> Grid<T> {
        assert!(
            win.x >= 0
                && win.y >= 0
                && win.x_end() as usize <= self.width
                && win.y_end() as usize <= self.height,
            "crop window {win:?} outside {}x{}",
            self.width,
            self.height
        );
        let mut data = Vec::with_capacity(win.len());
        for y in win.y as usize..win.y_end() as usize {
            data.extend_from_slice(&self.row(y)[win.x as usize..win.x_end() as usize]);
        }
        Grid {
            width: win.w,
            height: win.h,
            data,
        }
    }
    /// Paste `src` with its top-left at local (x, y); parts outside are clipped.
    pub fn paste(&mut self, src: &Grid<T>, x: i64, y: i64) {
        let me = Window::full(self.width, self.height);
        let Some(inter) = me.intersect(&Window::new(x, y, src.width, src.height)) else {
            return;
        };
        for yy in inter.y..inter.y_end() {
            let sx0 = (inter.x - x) as usize;
            let sy = (yy - y) as usize;
            let srow = &src.row(sy)[sx0..sx0 + inter.w];
            let dx0 = inter.x as usize;
            self.row_mut(yy as usize)[dx0..dx0 + inter.w].copy_from_slice(srow);
        }
    }
    /// Map every cell.
    pub fn map<U: Copy>(&self, f: impl Fn(T) -> U) -> Grid<U> {
        Grid {
            width: self.width,
            height: self.height,
            data: self.data.iter().map(|&v| f(v)).collect(),
        }
    }
}

/// A grid of any supported cell type (the native type of a file or store).
#[derive(Debug, Clone, PartialEq)]
pub enum AnyGrid {
    U8(Grid<u8>),
    I8(Grid<i8>),
    U16(Grid<u16>),
    I16(Grid<i16>),
    U32(Grid<u32>),
    I32(Grid<i32>),
    F32(Grid<f32>),
    F64(Grid<f64>),
}

/// Run `$body` with `$g` bound to the typed grid inside an [`AnyGrid`].
#[macro_export]
macro_rules! dispatch_any {
    ($any:expr, $g:ident => $body:expr) => {
        match $any {
            $crate::raster::AnyGrid::U8($g) => $body,
            $crate::raster::AnyGrid::I8($g) => $body,
            $crate::raster::AnyGrid::U16($g) => $body,
            $crate::raster::AnyGrid::I16($g) => $body,
            $crate::raster::AnyGrid::U32($g) => $body,
            $crate::raster::AnyGrid::I32($g) => $body,
            $crate::raster::AnyGrid::F32($g) => $body,
            $crate::raster::AnyGrid::F64($g) => $body,
        }
    };
}

/// Conversion of a typed grid into an [`AnyGrid`] and back.
pub trait IntoAny: Cell {
    /// Wrap.
    fn wrap(g: Grid<Self>) -> AnyGrid;
    /// Unwrap if the variant matches.
    fn unwrap_any(a: AnyGrid) -> Option<Grid<Self>>;
}

macro_rules! into_any {
    ($t:ty, $v:ident) => {
        impl IntoAny for $t {
            fn wrap(g: Grid<Self>) -> AnyGrid {
                AnyGrid::$v(g)
            }
            fn unwrap_any(a: AnyGrid) -> Option<Grid<Self>> {
                match a {
                    AnyGrid::$v(g) => Some(g),
                    _ => None,
                }
            }
        }
    };
}
into_any!(u8, U8);
into_any!(i8, I8);
into_any!(u16, U16);
into_any!(i16, I16);
into_any!(u32, U32);
into_any!(i32, I32);
into_any!(f32, F32);
into_any!(f64, F64);

impl AnyGrid {
    /// A grid of `dtype` filled with `v` (converted with [`Cell::from_f64`]).
    pub fn filled(dtype: DType, width: usize, height: usize, v: f64) -> AnyGrid {
        fn mk<T: IntoAny>(w: usize, h: usize, v: f64) -> AnyGrid {
            T::wrap(Grid::new(w, h, T::from_f64(v)))
        }
        match dtype {
            DType::U8 => mk::<u8>(width, height, v),
            DType::I8 => mk::<i8>(width, height, v),
            DType::U16 => mk::<u16>(width, height, v),
            DType::I16 => mk::<i16>(width, height, v),
            DType::U32 => mk::<u32>(width, height, v),
            DType::I32 => mk::<i32>(width, height, v),
            DType::F32 => mk::<f32>(width, height, v),
            DType::F64 => mk::<f64>(width, height, v),
        }
    }
    /// Build from little-endian bytes of `dtype` (length must match).
    pub fn from_le_bytes(dtype: DType, width: usize, height: usize, bytes: &[u8]) -> Result<AnyGrid> {
        fn mk<T: IntoAny>(w: usize, h: usize, b: &[u8]) -> Result<AnyGrid> {
            let n = w * h;
            if b.len() != n * std::mem::size_of::<T>() {
                return Err(Error::invalid(format!(
                    "expected {} bytes for {w}x{h} {}, got {}",
                    n * std::mem::size_of::<T>(),
                    T::DTYPE,
                    b.len()
                )));
            }
            let mut v = vec![T::default(); n];
            bytemuck::cast_slice_mut::<T, u8>(&mut v).copy_from_slice(b);
            Ok(T::wrap(Grid::from_vec(w, h, v)?))
        }
        match dtype {
            DType::U8 => mk::<u8>(width, height, bytes),
            DType::I8 => mk::<i8>(width, height, bytes),
            DType::U16 => mk::<u16>(width, height, bytes),
            DType::I16 => mk::<i16>(width, height, bytes),
            DType::U32 => mk::<u32>(width, height, bytes),
            DType::I32 => mk::<i32>(width, height, bytes),
            DType::F32 => mk::<f32>(width, height, bytes),
            DType::F64 => mk::<f64>(width, height, bytes),
        }
    }
    /// Little-endian bytes of the cells (this crate only builds on little-endian targets).
    pub fn as_le_bytes(&self) -> &[u8] {
        dispatch_any!(self, g => bytemuck::cast_slice(g.data()))
    }
    /// Cell type.
    pub fn dtype(&self) -> DType {
        match self {
            AnyGrid::U8(_) => DType::U8,
            AnyGrid::I8(_) => DType::I8,
            AnyGrid::U16(_) => DType::U16,
            AnyGrid::I16(_) => DType::I16,
            AnyGrid::U32(_) => DType::U32,
            AnyGrid::I32(_) => DType::I32,
            AnyGrid::F32(_) => DType::F32,
            AnyGrid::F64(_) => DType::F64,
        }
    }
    /// Columns.
    pub fn width(&self) -> usize {
        dispatch_any!(self, g => g.width())
    }
    /// Rows.
    pub fn height(&self) -> usize {
        dispatch_any!(self, g => g.height())
    }
    /// Value at (x, y) as f64.
    pub fn get_f64(&self, x: usize, y: usize) -> f64 {
        dispatch_any!(self, g => g.get(x, y).to_f64())
    }
    /// Convert to `Grid<T>`. For float `T`, cells equal to `nodata` (or NaN)
    /// become NaN; for integer `T` values convert with [`Cell::from_f64`].
    pub fn to_typed<T: Cell>(&self, nodata: Option<f64>) -> Grid<T> {
        let float_out = T::DTYPE.is_float();
        dispatch_any!(self, g => {
            let nan = T::from_f64(f64::NAN);
            g.map(|v| {
                let f = v.to_f64();
                if float_out && (f.is_nan() || Some(f) == nodata) {
                    nan
                } else {
                    T::from_f64(f)
                }
            })
        })
    }
    /// Convert a typed grid to `dtype`, writing NaN cells as `nodata`
    /// (or 0 / NaN when there is no nodata value).
    pub fn from_typed<T: Cell>(g: &Grid<T>, dtype: DType, nodata: Option<f64>) -> AnyGrid {
        fn conv<T: Cell, U: IntoAny>(g: &Grid<T>, nodata: Option<f64>) -> AnyGrid {
            let nd = U::from_f64(nodata.unwrap_or(f64::NAN));
            U::wrap(g.map(|v| {
                let f = v.to_f64();
                if f.is_nan() {
                    nd
                } else {
                    U::from_f64(f)
                }
            }))
        }
        match dtype {
            DType::U8 => conv::<T, u8>(g, nodata),
            DType::I8 => conv::<T, i8>(g, nodata),
            DType::U16 => conv::<T, u16>(g, nodata),
            DType::I16 => conv::<T, i16>(g, nodata),
            DType::U32 => conv::<T, u32>(g, nodata),
            DType::I32 => conv::<T, i32>(g, nodata),
            DType::F32 => conv::<T, f32>(g, nodata),
            DType::F64 => conv::<T, f64>(g, nodata),
        }
    }
    /// Copy of a sub-rectangle (local coordinates, inside).
    pub fn crop(&self, win: Window) -> AnyGrid {
        fn c<T: IntoAny>(g: &Grid<T>, w: Window) -> AnyGrid {
            T::wrap(g.crop(w))
        }
        dispatch_any!(self, g => c(g, win))
    }
    /// Paste `src` (same dtype) at local (x, y), clipped. Panics on dtype mismatch.
    pub fn paste(&mut self, src: &AnyGrid, x: i64, y: i64) {
        match (self, src) {
            (AnyGrid::U8(d), AnyGrid::U8(s)) => d.paste(s, x, y),
            (AnyGrid::I8(d), AnyGrid::I8(s)) => d.paste(s, x, y),
            (AnyGrid::U16(d), AnyGrid::U16(s)) => d.paste(s, x, y),
            (AnyGrid::I16(d), AnyGrid::I16(s)) => d.paste(s, x, y),
            (AnyGrid::U32(d), AnyGrid::U32(s)) => d.paste(s, x, y),
            (AnyGrid::I32(d), AnyGrid::I32(s)) => d.paste(s, x, y),
            (AnyGrid::F32(d), AnyGrid::F32(s)) => d.paste(s, x, y),
            (AnyGrid::F64(d), AnyGrid::F64(s)) => d.paste(s, x, y),
            (d, s) => panic!("paste of {} into {}", s.dtype(), d.dtype()),
        }
    }
}
