//! The filter state behind one interface, [`FilterState`]: what the
//! identification step ([`crate::identify::Kernel`]) needs of a filter.
//!
//! | state | filter | entries of `F` | implements |
//! |---|---|---|---|
//! | [`DenseFactor<F, M>`] | dense Givens ([`crate::qrdrls`]), any rows | `M^2 + M` | [`Factor`] |
//! | [`BlockFactor<F, NB, W, S>`] | Givens block ([`crate::blockqrd`]) | `NB W^2 + NB W S + S^2 + M` | [`Factor`] |
//! | [`SqrtFreeFactor<F, NB, W, S>`] | square-root-free block ([`crate::sqrtfree`]) | the same, the diagonal real | [`Factor`] |
//! | [`FactorMut`] | dense Givens on caller slices (the desktop driver's run-time sizes) | `M^2 + M` | |
//!
//! [`Factor`] is inline storage a const-generic
//! [`crate::identify::Identifier`] owns (the identifier's `R`); the step
//! works on `&mut R`, so a firmware build holds only the filter it uses.
//! [`QrdRls<F, R>`] owns one with its forgetting factor, for use without
//! an identifier: [`crate::blockqrd::BlockQrdRls`] and
//! [`crate::sqrtfree::SqrtFreeQrdRls`] are its aliases (the dense
//! [`crate::qrdrls::VectorQrdRls`] has an array interface of its own:
//! prior weights, `N` rows per step as arrays, a reset).
//!
//! The Givens filters give the same numbers to the last bit (see
//! [`crate::blockqrd`]); the square-root-free one the same to round-off,
//! with fewer instructions and a narrower input range (see
//! [`crate::sqrtfree`]).

use crate::blockqrd::{BlockFactor, BlockShape};
use crate::qrdrls::{self, FilterError};
use crate::sqrtfree::SqrtFreeFactor;
use crate::Real;
use core::fmt::Debug;
use nalgebra::ComplexField;

/// What the identification step needs of a filter state.
pub trait FilterState<F: ComplexField> {
    /// Number of unknowns `M`.
    fn unknowns(&self) -> usize;
    /// The block layout, `None` for a dense factor.
    fn shape(&self) -> Option<BlockShape>;
    /// `R = sqrt(delta) I`, `p = 0` (`InvalidDelta` unless `delta` lies in
    /// `(0, sqrt(T::MAX)]`, state untouched).
    fn init(&mut self, delta: F::RealField) -> Result<(), FilterError>;
    /// Folds in `N` rows of `M` entries; errors leave the state unchanged.
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

/// A state the step borrows (the identifier hands its storage over as
/// `&mut R`).
impl<F: ComplexField, V: FilterState<F> + ?Sized> FilterState<F> for &mut V {
    fn unknowns(&self) -> usize {
        (**self).unknowns()
    }
    fn shape(&self) -> Option<BlockShape> {
        (**self).shape()
    }
    fn init(&mut self, delta: F::RealField) -> Result<(), FilterError> {
        (**self).init(delta)
    }
    #[inline(always)]
    fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: F::RealField,
        xi: &mut [F],
        gamma: &mut [F::RealField],
    ) -> Result<(), FilterError> {
        (**self).update_rows(u, d, lambda, xi, gamma)
    }
    #[inline(always)]
    fn update_grouped_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: F::RealField,
        xi: &mut [F],
        gamma: &mut [F::RealField],
    ) -> Result<(), FilterError> {
        (**self).update_grouped_rows(u, d, lambda, xi, gamma)
    }
    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        (**self).solve_weights(w)
    }
    fn diag_ratio(&self) -> Result<F::RealField, FilterError> {
        (**self).diag_ratio()
    }
}

/// The dense state on caller slices (the desktop driver's, sizes known at
/// run time).
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

impl<F, T> FilterState<F> for FactorMut<'_, F>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    fn unknowns(&self) -> usize {
        let FactorMut::Dense { p, .. } = self;
        p.len()
    }
    fn shape(&self) -> Option<BlockShape> {
        None
    }
    fn init(&mut self, delta: T) -> Result<(), FilterError> {
        let FactorMut::Dense { r, p } = self;
        qrdrls::init(r, p, delta, None)
    }
    fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        let FactorMut::Dense { r, p } = self;
        qrdrls::update_rows(r, p, u, d, lambda, xi, gamma)
    }
    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        let FactorMut::Dense { r, p } = self;
        qrdrls::solve_weights(r, p, w)
    }
    fn diag_ratio(&self) -> Result<T, FilterError> {
        let FactorMut::Dense { r, .. } = self;
        qrdrls::r_diag_ratio(r)
    }
}

/// Inline storage of a filter state, owned by a const-generic identifier
/// or a [`QrdRls`].
pub trait Factor<F: ComplexField>: FilterState<F> + Clone + Debug + PartialEq {
    /// All zero (then [`FilterState::init`]).
    fn zeroed() -> Self;
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
}

impl<F, T, const M: usize> FilterState<F> for DenseFactor<F, M>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    fn unknowns(&self) -> usize {
        M
    }
    fn shape(&self) -> Option<BlockShape> {
        None
    }
    fn init(&mut self, delta: T) -> Result<(), FilterError> {
        qrdrls::init(self.r.as_flattened_mut(), &mut self.p, delta, None)
    }
    fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        lambda: T,
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        let r = self.r.as_flattened_mut();
        qrdrls::update_rows(r, &mut self.p, u, d, lambda, xi, gamma)
    }
    fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        qrdrls::solve_weights(self.r.as_flattened(), &self.p, w)
    }
    fn diag_ratio(&self) -> Result<T, FilterError> {
        qrdrls::r_diag_ratio(self.r.as_flattened())
    }
}

impl<F, T, const M: usize> Factor<F> for DenseFactor<F, M>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
{
    fn zeroed() -> Self {
        DenseFactor {
            r: [[F::zero(); M]; M],
            p: [F::zero(); M],
        }
    }
}

/// [`FilterState`] and [`Factor`] for a block-layout storage
/// `$storage<F, NB, W, S>` whose own methods are the filter's: `SHAPE`,
/// `zeroed`, `init` (checked), `update_rows`, `solve_weights` and
/// `diag_ratio`; with `, update_grouped_rows`, its own form for grouped
/// rows too (otherwise grouped rows are rows). The Givens block and the
/// square-root-free filters have the same interface this way.
macro_rules! block_filter_state {
    ($storage:ident $(, $grouped:ident)?) => {
        impl<F, T, const NB: usize, const W: usize, const S: usize> FilterState<F>
            for $storage<F, NB, W, S>
        where
            F: ComplexField<RealField = T> + Copy,
            T: Real,
        {
            fn unknowns(&self) -> usize {
                Self::SHAPE.unknowns()
            }
            fn shape(&self) -> Option<BlockShape> {
                Some(Self::SHAPE)
            }
            fn init(&mut self, delta: T) -> Result<(), FilterError> {
                $storage::init(self, delta)
            }
            #[inline(always)]
            fn update_rows(
                &mut self,
                u: &[F],
                d: &[F],
                lambda: T,
                xi: &mut [F],
                gamma: &mut [T],
            ) -> Result<(), FilterError> {
                $storage::update_rows(self, u, d, lambda, xi, gamma)
            }
            $(
                #[inline(always)]
                fn $grouped(
                    &mut self,
                    u: &[F],
                    d: &[F],
                    lambda: T,
                    xi: &mut [F],
                    gamma: &mut [T],
                ) -> Result<(), FilterError> {
                    $storage::$grouped(self, u, d, lambda, xi, gamma)
                }
            )?
            fn solve_weights(&self, w: &mut [F]) -> Result<(), FilterError> {
                $storage::solve_weights(self, w)
            }
            fn diag_ratio(&self) -> Result<T, FilterError> {
                Ok($storage::diag_ratio(self))
            }
        }

        impl<F, T, const NB: usize, const W: usize, const S: usize> Factor<F>
            for $storage<F, NB, W, S>
        where
            F: ComplexField<RealField = T> + Copy,
            T: Real,
        {
            fn zeroed() -> Self {
                $storage::zeroed()
            }
        }
    };
}

block_filter_state!(BlockFactor);
block_filter_state!(SqrtFreeFactor, update_grouped_rows);

/// An owning, fixed-size QRD/RLS filter: a state `R` ([`Factor`]) and its
/// forgetting factor `lambda`. Aliases: [`crate::blockqrd::BlockQrdRls`]
/// (Givens block), [`crate::sqrtfree::SqrtFreeQrdRls`] (square-root-free
/// block).
#[derive(Clone, Debug, PartialEq)]
pub struct QrdRls<F: ComplexField, R> {
    factor: R,
    lambda: F::RealField,
}

impl<F, T, R> QrdRls<F, R>
where
    F: ComplexField<RealField = T> + Copy,
    T: Real,
    R: Factor<F>,
{
    /// A fresh filter: `R = sqrt(delta) I`, `p = 0`, forgetting factor
    /// `lambda`.
    ///
    /// Errors: `InvalidLambda` (`lambda` not in `(0, 1]`), `InvalidDelta`
    /// (`delta` not in `(0, sqrt(T::MAX)]`).
    pub fn new(lambda: T, delta: T) -> Result<Self, FilterError> {
        qrdrls::validate_lambda(lambda)?;
        let mut factor = R::zeroed();
        factor.init(delta)?;
        Ok(QrdRls { factor, lambda })
    }

    /// The forgetting factor.
    pub fn lambda(&self) -> T {
        self.lambda
    }

    /// The stored state.
    pub fn factor(&self) -> &R {
        &self.factor
    }

    /// The stored state, for updates of a particular filter's own forms.
    #[cfg(feature = "compact-rows")]
    pub(crate) fn factor_mut(&mut self) -> &mut R {
        &mut self.factor
    }

    /// Folds in the `N` rows of `u` (`N x M` row-major) with right-hand
    /// sides `d`, using the filter's `lambda`; writes the a-posteriori
    /// errors `xi` and the conversion factors `gamma` ([`FilterState::update_rows`]).
    ///
    /// Errors (state untouched): as the state's `update_rows`.
    pub fn update_rows(
        &mut self,
        u: &[F],
        d: &[F],
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        self.factor.update_rows(u, d, self.lambda, xi, gamma)
    }

    /// [`Self::update_rows`] for rows in the block layout's groups
    /// ([`FilterState::update_grouped_rows`]: `NB` groups of `N / NB`
    /// rows, group `b` in block `b`; the square-root-free filter reads only
    /// each row's block and shared entries).
    pub fn update_grouped_rows(
        &mut self,
        u: &[F],
        d: &[F],
        xi: &mut [F],
        gamma: &mut [T],
    ) -> Result<(), FilterError> {
        self.factor
            .update_grouped_rows(u, d, self.lambda, xi, gamma)
    }

    /// The weights `w = R^-1 p` into `w` (`M` entries).
    pub fn weights(&self, w: &mut [F]) -> Result<(), FilterError> {
        self.factor.solve_weights(w)
    }
}
