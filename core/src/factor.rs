//! The filter state of an identifier: the dense QRD/RLS factor
//! ([`crate::qrdrls`], `M x M`) or the block-structured one
//! ([`crate::blockqrd`], only the blocks), behind one interface.
//!
//! [`FactorMut`] / [`FactorRef`] are views on caller storage (slices), so
//! the same identification step ([`crate::identify::Kernel`]) runs on the
//! firmware's inline arrays and on the desktop's vectors. [`Factor`] is the
//! inline storage a const-generic [`crate::identify::Identifier`] owns:
//! [`DenseFactor`] (`M^2 + M` entries) or [`BlockFactor`]
//! (`NB W^2 + NB W S + S^2 + 2 M` entries). Both give the same numbers (see
//! [`crate::blockqrd`]); the dense one serves any row structure. The
//! square-root-free [`crate::sqrtfree::SqrtFreeFactor`] (the block layout,
//! Gentleman's rotations) is a third storage: fewer instructions, the same
//! numbers to round-off, a narrower input range.

use crate::blockqrd::{BlockFactor, BlockShape};
use crate::qrdrls::{self, FilterError};
use crate::Real;
use core::fmt::Debug;
use nalgebra::ComplexField;

/// Mutable view of a filter state.
#[derive(Debug)]
pub enum FactorMut<'a, F> {
    /// Dense factor: `r` row-major `M x M`, `p` (`M`).
    Dense {
        /// Factor `R`.
        r: &'a mut [F],
        /// Rotated right-hand side `p`.
        p: &'a mut [F],
    },
}

/// Read-only view of a filter state.
#[derive(Debug, Clone, Copy)]
pub enum FactorRef<'a, F> {
    /// Dense factor: `r` row-major `M x M`, `p` (`M`).
    Dense {
        /// Factor `R`.
        r: &'a [F],
        /// Rotated right-hand side `p`.
        p: &'a [F],
    },
}

impl<F, T> FactorMut<'_, F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// Number of unknowns `M`.
    pub fn unknowns(&self) -> usize {
        match self {
            FactorMut::Dense { p, .. } => p.len(),
        }
    }

    /// The block layout: `None`, the factor is dense.
    pub fn shape(&self) -> Option<BlockShape> {
        None
    }

    /// `R = sqrt(delta) I`, `p = 0` ([`qrdrls::init`]).
    pub fn init(&mut self, delta: T) -> Result<(), FilterError> {
        match self {
            FactorMut::Dense { r, p } => qrdrls::init(r, p, delta, None),
        }
    }

    /// Folds in `N` rows ([`qrdrls::update_rows`]);
    /// errors leave the state unchanged.
    pub fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        match self {
            FactorMut::Dense { r, p } => qrdrls::update_rows(r, p, u, d, lambda, xi, gamma),
        }
    }

    /// The read-only view.
    pub fn as_ref(&self) -> FactorRef<'_, F> {
        match self {
            FactorMut::Dense { r, p } => FactorRef::Dense { r, p },
        }
    }
}

impl<F, T> FactorRef<'_, F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    /// Back-substitution `R w = p` into `w` (`M` entries).
    pub fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        match self {
            FactorRef::Dense { r, p } => qrdrls::solve_weights(r, p, w),
        }
    }

    /// `min|R_ii| / max|R_ii|`.
    pub fn diag_ratio(&self) -> Result<T, FilterError> {
        match self {
            FactorRef::Dense { r, .. } => qrdrls::r_diag_ratio(r),
        }
    }
}

/// What the identification step needs of a filter state (implemented by
/// the dense slices [`FactorMut`] and [`DenseMut`] and the inline block
/// storages, so that a firmware build holds only the filter it uses).
pub trait FilterState<F: ComplexField> {
    /// Number of unknowns `M`.
    fn unknowns(&self) -> usize;
    /// The block layout, `None` for a dense factor.
    fn shape(&self) -> Option<BlockShape>;
    /// `R = sqrt(delta) I`, `p = 0`.
    fn init(&mut self, delta: F::RealField) -> Result<(), FilterError>;
    /// Folds in `N` rows; errors leave the state unchanged.
    fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: F::RealField,
        xi: &mut [F],
        gamma: &mut [F::RealField],
    ) -> Result<(), FilterError>;
    /// Folds in `N` rows of `M` entries that the caller built in the block
    /// layout's groups: `NB` consecutive groups of `N / NB` rows, group `b`
    /// zero outside block `b` and the shared columns (the identification's
    /// rows). A block filter may then read only those entries (the
    /// square-root-free one does); by default this is [`Self::update_rows`],
    /// which checks the structure.
    fn update_grouped_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: F::RealField,
        xi: &mut [F],
        gamma: &mut [F::RealField],
    ) -> Result<(), FilterError> {
        self.update_rows(u, d, lambda, xi, gamma)
    }
    /// Back-substitution `R w = p` into `w` (`M` entries).
    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError>;
    /// `min|R_ii| / max|R_ii|`.
    fn diag_ratio(&self) -> Result<F::RealField, FilterError>;
}

impl<F, T> FilterState<F> for FactorMut<'_, F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    fn unknowns(&self) -> usize {
        FactorMut::unknowns(self)
    }
    fn shape(&self) -> Option<BlockShape> {
        FactorMut::shape(self)
    }
    fn init(&mut self, delta: T) -> Result<(), FilterError> {
        FactorMut::init(self, delta)
    }
    fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        FactorMut::update_rows(self, u, d, lambda, xi, gamma)
    }
    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        self.as_ref().solve_weights(w)
    }
    fn diag_ratio(&self) -> Result<T, FilterError> {
        self.as_ref().diag_ratio()
    }
}

/// Mutable view of a dense state: `r` row-major `M x M`, `p` (`M`).
#[derive(Debug)]
pub struct DenseMut<'a, F> {
    /// Factor `R`.
    pub r: &'a mut [F],
    /// Rotated right-hand side `p`.
    pub p: &'a mut [F],
}

impl<F, T> FilterState<F> for DenseMut<'_, F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    fn unknowns(&self) -> usize {
        self.p.len()
    }
    fn shape(&self) -> Option<BlockShape> {
        None
    }
    fn init(&mut self, delta: T) -> Result<(), FilterError> {
        qrdrls::init(self.r, self.p, delta, None)
    }
    fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        qrdrls::update_rows(self.r, self.p, u, d, lambda, xi, gamma)
    }
    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        qrdrls::solve_weights(self.r, self.p, w)
    }
    fn diag_ratio(&self) -> Result<T, FilterError> {
        qrdrls::r_diag_ratio(self.r)
    }
}

/// Inline storage of a filter state, owned by a const-generic identifier.
pub trait Factor<F: ComplexField>: Clone + Debug + PartialEq {
    /// The mutable view the identification step works on.
    type View<'a>: FilterState<F>
    where
        Self: 'a;
    /// All zero (the identifier initialises it).
    fn zeroed() -> Self;
    /// Mutable view (static dispatch).
    fn view_mut(&mut self) -> Self::View<'_>;
    /// Back-substitution for the weights `w` (`M` entries).
    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError>;
    /// `min|R_ii| / max|R_ii|`.
    fn diag_ratio(&self) -> Result<F::RealField, FilterError>;
}

/// Dense `M x M` factor and `p`: `M^2 + M` entries of `F`.
#[derive(Clone, Debug, PartialEq)]
pub struct DenseFactor<F, const M: usize> {
    r: [[F; M]; M],
    p: [F; M],
}

impl<F, const M: usize> DenseFactor<F, M> {
    /// The triangular factor `R` and the rotated right-hand side `p`.
    pub fn parts(&self) -> (&[[F; M]; M], &[F; M]) {
        (&self.r, &self.p)
    }

    /// Read-only view.
    pub fn view(&self) -> FactorRef<'_, F> {
        FactorRef::Dense {
            r: self.r.as_flattened(),
            p: &self.p,
        }
    }
}

impl<F, T, const M: usize> Factor<F> for DenseFactor<F, M>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    type View<'a>
        = DenseMut<'a, F>
    where
        Self: 'a;

    fn zeroed() -> Self {
        DenseFactor {
            r: [[F::zero(); M]; M],
            p: [F::zero(); M],
        }
    }

    fn view_mut(&mut self) -> DenseMut<'_, F> {
        DenseMut {
            r: self.r.as_flattened_mut(),
            p: &mut self.p,
        }
    }

    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        DenseFactor::view(self).solve_weights(w)
    }

    fn diag_ratio(&self) -> Result<T, FilterError> {
        DenseFactor::view(self).diag_ratio()
    }
}

/// Mutable view of an inline block-structured factor with its layout
/// known at compile time: the update runs the fixed-size kernel
/// [`BlockFactor::update_rows`]; the rest goes through the read view.
#[derive(Debug)]
pub struct BlockFixedMut<'a, F, const NB: usize, const W: usize, const S: usize>(
    pub &'a mut BlockFactor<F, NB, W, S>,
);

impl<F, T, const NB: usize, const W: usize, const S: usize> FilterState<F>
    for BlockFixedMut<'_, F, NB, W, S>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    fn unknowns(&self) -> usize {
        BlockFactor::<F, NB, W, S>::SHAPE.unknowns()
    }
    fn shape(&self) -> Option<BlockShape> {
        Some(BlockFactor::<F, NB, W, S>::SHAPE)
    }
    fn init(&mut self, delta: T) -> Result<(), FilterError> {
        self.0.init(delta)
    }
    fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        self.0.update_rows(u, d, lambda, xi, gamma)
    }
    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        self.0.view().solve_weights(w)
    }
    fn diag_ratio(&self) -> Result<T, FilterError> {
        Ok(self.0.view().diag_ratio())
    }
}

impl<F, T, const NB: usize, const W: usize, const S: usize> Factor<F> for BlockFactor<F, NB, W, S>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    type View<'a>
        = BlockFixedMut<'a, F, NB, W, S>
    where
        Self: 'a;

    fn zeroed() -> Self {
        BlockFactor::zeroed()
    }

    fn view_mut(&mut self) -> BlockFixedMut<'_, F, NB, W, S> {
        BlockFixedMut(self)
    }

    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        BlockFactor::view(self).solve_weights(w)
    }

    fn diag_ratio(&self) -> Result<T, FilterError> {
        Ok(BlockFactor::view(self).diag_ratio())
    }
}
