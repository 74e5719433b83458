//! Why a call was refused. The numeric values are the C status codes
//! (`MSBSDF_STATUS_*`) and never change or get reused.

use std::fmt;

/// An error returned by the Rust API; `as u32` is the C status code.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u32)]
pub enum Error {
    /// A required pointer was NULL.
    NullPointer = 1,
    /// A parameter is out of its valid range (roughness, index, bounces...).
    InvalidArgument = 2,
    /// The model, facet and NDF combination is not supported (yet).
    Unsupported = 3,
    /// Memory could not be allocated.
    OutOfMemory = 4,
    /// An internal panic was caught at the C boundary (a bug: please report).
    Panic = 5,
    /// `struct_size` is smaller than the oldest supported struct layout.
    StructTooSmall = 6,
    /// Caller-provided storage is smaller than `msbsdf_material_size()`.
    StorageTooSmall = 7,
    /// Caller-provided storage is not aligned to `msbsdf_material_align()`.
    StorageMisaligned = 8,
    /// A direction is NaN, infinite or zero-length.
    InvalidDirection = 9,
    /// A model, NDF, facet or estimator constant is not one this library knows.
    UnknownConstant = 10,
}

impl Error {
    /// Static human-readable text.
    pub fn message(self) -> &'static str {
        match self {
            Error::NullPointer => "a required pointer argument is NULL",
            Error::InvalidArgument => "a parameter is outside its valid range",
            Error::Unsupported => "this model / facet / NDF combination is not supported",
            Error::OutOfMemory => "out of memory",
            Error::Panic => "internal error (a panic was caught at the C boundary)",
            Error::StructTooSmall => "struct_size is smaller than any supported struct layout",
            Error::StorageTooSmall => "storage is smaller than msbsdf_material_size()",
            Error::StorageMisaligned => "storage is not aligned to msbsdf_material_align()",
            Error::InvalidDirection => "a direction is NaN, infinite or of zero length",
            Error::UnknownConstant => "unknown model, NDF, facet or estimator constant",
        }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.message())
    }
}

impl std::error::Error for Error {}
