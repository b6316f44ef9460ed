//! The first moment `integral over P ∩ D of (1 - |u|^2) u du` of a convex polygon `P` against
//! the unit disc `D`: where the kernel's mass in a view footprint lies, so that a weight that
//! varies linearly over the footprint (image area per surface area, `estimate::ExactFootprint`)
//! is read at its centroid, exactly.
//!
//! Derivation, fan triangle by fan triangle as for the integral ([`super`]): the triangle from
//! the origin to the side on the line `u(t) = h nu + t tau` (`nu` the outward normal, `tau`
//! the tangent, `t in [t0, t1]`), in polar coordinates `u = r e(phi)`, holds
//! `integral e(phi) (R^3 / 3 - R^5 / 5) dphi` with `R = min(|u(t)|, 1)`. Along the side
//! `dphi = h dt / rho^2` and `e = u(t) / rho`, `rho^2 = h^2 + t^2`, so:
//! - where the side lies inside the disc (`|t| <= w = sqrt(1 - h^2)`, `t in [u0, u1]`), the
//!   integrand is `h (h nu + t tau)(1/3 - (h^2 + t^2)/5)`, a polynomial:
//!   `nu h^2 (c (u1 - u0) - (u1^3 - u0^3)/15) + tau h (c (u1^2 - u0^2)/2 - (u1^4 - u0^4)/20)`,
//!   `c = 1/3 - h^2/5`;
//! - where it lies outside (`[t0, u0]` and `[u1, t1]`), `R = 1` and the integrand is
//!   `(2/15) e dphi`, whose integral is `(2/15) (F(e_end) - F(e_start))` with
//!   `F(e) = (e_y, -e_x)`. Summed over the sides the terms at the polygon's vertices cancel
//!   (each vertex ends one side and starts the next), and so do those at a side's `u0`, `u1`
//!   where they coincide with a vertex inside the disc; what is left is
//!   `(2/15) F(sum over sides of u(u0) - u(u1))`, where every remaining point lies on the
//!   circle (`|u| = 1`, so `e = u`): no square root and no angle.

use super::{Clipped, Lane};

/// The first moment (x, y) of `(1 - |u|^2)` over `P ∩ D` for the convex counter-clockwise
/// polygon whose sides are as the integral's sides take them ([`Clipped`]), with unit tangents
/// `(tau_x, tau_y)` (the outward normal is `(tau_y, -tau_x)`).
#[inline(always)]
pub fn first_moment<T: Lane, const N: usize>(
    sides: &[Clipped<T>; N],
    tangents: &[(T, T); N],
) -> (T, T) {
    let (mut mx, mut my) = (T::splat(0.0), T::splat(0.0));
    // Sum over sides of u(u0) - u(u1) = (u0 - u1) tau (the nu parts cancel within a side).
    let (mut ax, mut ay) = (T::splat(0.0), T::splat(0.0));
    for (side, &(tx, ty)) in sides.iter().zip(tangents) {
        let &Clipped { h, hh, u0, u1, .. } = side;
        let c = T::splat(1.0 / 3.0) - hh * T::splat(0.2);
        let (s0, s1) = (u0 * u0, u1 * u1);
        let along_normal = hh * (c * (u1 - u0) - (s1 * u1 - s0 * u0) * T::splat(1.0 / 15.0));
        let along_tangent =
            h * (c * T::splat(0.5) * (s1 - s0) - (s1 * s1 - s0 * s0) * T::splat(0.05));
        // nu = (ty, -tx).
        mx = mx + along_normal * ty + along_tangent * tx;
        my = my - along_normal * tx + along_tangent * ty;
        let d = u0 - u1;
        ax = ax + d * tx;
        ay = ay + d * ty;
    }
    let arc = T::splat(2.0 / 15.0);
    (mx + arc * ay, my - arc * ax)
}
