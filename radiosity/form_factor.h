// Form-factor math of the radiosity stage (internal header).
//
// Two families of quantities are computed here:
//  * the classic point-to-polygon and patch-to-patch factors, used by the
//    constant-patch baseline and as the analytic totals of the bilinear method;
//  * the bilinear vertex kernel of Bian, Wittels & Fussell (paper eq. 5),
//    K_j = ∫ N_j cosθp cosθq /(π r²) dA, from a receiver vertex to the four
//    shape functions of a planar source quad.
//
// Conventions shared by every function:
//  * A source polygon is planar and convex; its front is given by the
//    right-hand rule on its vertex order (counter-clockwise seen from the
//    front). Surfaces are one-sided: a receiver behind or in the source's
//    plane gets 0.
//  * Only the part of the source above the receiver's horizon, n·(q−p) > 0,
//    counts. Polygons are clipped at that plane before any contour sum,
//    because the unclipped contour formula silently adds the part of the
//    polygon's projection that lies below the horizon with the wrong sign.
//  * Consecutive duplicate vertices are dropped, so a triangle stored as a
//    quad with two equal vertices works everywhere.
//  * A receiver vertex that lies on a crease (a source's edge or corner) takes
//    the limit of the field from inside its own face, along `approach`.
#pragma once

#include <array>

#include "core/core.h"

namespace radbake {

// F(p, n -> P) = ∫_P cosθp cosθq /(π r²) dA by hemisphere projection: the
// polygon is clipped at the receiver's horizon, then the contour sum
// (1/2π) Σ_edges γ_i (n · unit normal of the edge's great circle) is taken
// (Lambert's formula; equal to the paper's elliptical-sector sum eq. 7).
// Returns 0 when p is behind the polygon's plane or in it (within a relative
// tolerance of 1e-10 of the polygon size), or when fewer than 3 distinct
// vertices remain.
double pointPolygonFactor(const Vec3& p, const Vec3& n, const Vec3* polygon, int count);

// lim_{e->0+} pointPolygonFactor(p + e*approach, n, P) for p on P's boundary
// (within 1e-10 of the polygon size). As e -> 0 the polygon seen from
// p + e*approach becomes its tangent cone at p (a half-plane at an edge point,
// the corner's wedge at a vertex); a cone is scale invariant, so it is
// evaluated exactly from p + approach on the unit sphere. `approach` should be
// tangent to the receiver's face and point into it; 0 if it does not point to
// the front of P. If p is not on P's boundary this is pointPolygonFactor(p, ...).
double pointPolygonFactorLimit(const Vec3& p, const Vec3& n, const Vec3& approach, const Vec3* polygon,
                               int count);

struct KernelOptions {
  // Target relative accuracy of every K_j, relative to the total Σ_j K_j.
  // It selects the Gauss-Legendre order of each quadrature cell (see
  // gaussOrderForRatio); the analytic total is always exact.
  double relativeTolerance = 1e-6;
};

// The paper's bilinear kernel from a receiver vertex (p, n) to the shape
// functions of a planar source quad (CCW, isoparametric map
// x(s,t) = Σ N_j(s,t) q_j, N_0 = (1-s)(1-t)/4, N_1 = (1+s)(1-t)/4,
// N_2 = (1+s)(1+t)/4, N_3 = (1-s)(1+t)/4, s,t in [-1,1]; a triangle is a quad
// with q[2] == q[3]).
//
// Scheme: let (s*,t*) be the source point nearest to p and F the analytic,
// horizon-clipped total. Then K_j = N_j(s*,t*) F + ∫ (N_j − N_j(s*,t*)) k dA,
// so Σ_j K_j = F to rounding and the remainder integrand vanishes where the
// kernel peaks. The remainder is integrated by tensor Gauss-Legendre on cells
// of the (s,t) square: a cell closer to p than its own size (bounding-sphere
// distance and diameter) is split in four, which grades the cells
// geometrically toward p*, and each remaining cell uses the order
// gaussOrderForRatio(distance/size). A far source is a single cell (2-6
// points per direction); cells entirely below the horizon are skipped.
// Inside a cell the horizon is handled exactly: n·(x(s,t) − p) is bilinear, so
// for every s-node the visible t-range is found in closed form.
//
// p exactly on the source's boundary (a shared edge or corner): all of the
// limit factor sits at p, so K_j = N_j(p) pointPolygonFactorLimit(...).
// p inside the source, in its plane (a block standing on a floor patch): the
// limit is the source's whole plane, (1 − n·m)/2 for source normal m, again all
// at p; 0 unless `approach` points to the source's front.
// `approach` is a unit vector tangent to the receiver's face pointing into it
// (the corner bisector for a patch-corner vertex); only used in that case.
std::array<double, 4> vertexQuadKernel(const Vec3& p, const Vec3& n, const Vec3& approach,
                                       const std::array<Vec3, 4>& quad, const KernelOptions& options = {});

// The same cell quadrature applied to the plain kernel (no analytic total, no
// subtraction): F(p, n -> quad) by Gauss-Legendre alone. Exists to check the
// quadrature path against the analytic factor; the baker does not need it.
double quadratureQuadFactor(const Vec3& p, const Vec3& n, const std::array<Vec3, 4>& quad,
                            const KernelOptions& options = {});

// Gauss-Legendre order for one quadrature cell whose nearest point is
// `ratio` cell sizes away from the receiver, so the cell's relative error
// stays below `relativeTolerance` (measured rule, see form_factor.cpp).
int gaussOrderForRatio(double ratio, double relativeTolerance);

// F(A -> B) = (1/|A|) ∫_A ∫_B cosθ cosθ /(π r²) dB dA with full visibility,
// one-sided. A is first clipped to the front half-space of B's plane, and cut
// across at the ends of any contact with B that covers only part of an edge
// (a wall standing inside a floor patch), so every singularity of the
// integrand lies on whole edges or corners of the pieces. The point factor
// (its limit where A touches B) is integrated over each piece by tensor
// tanh-sinh quadrature, whose nodes cluster at the piece's edges where the
// integrand has its x log x behaviour; levels are refined until the relative
// change is below `change` (1e-8: the finer level is then good to ~1e-13). A and B are
// planar convex polygons (triangles stored as quads with a repeated vertex
// included).
double patchPatchFactor(const Vec3* from, int fromCount, const Vec3* to, int toCount, double change = 1e-8);

// F(A -> B) for the constant-patch method: tensor Gauss-Legendre over A of the
// analytic point factor, its order from gaussOrderForRatio (distance between
// bounding spheres over A's diameter) for `relativeTolerance`, where that ratio
// is at least 1, or from 0.5 where the order is at most 6 (then over the part of
// A in front of B's plane); closer, patchPatchFactor (tanh-sinh) to a relative
// change of a hundredth of the tolerance.
double constantPatchFactor(const std::array<Vec3, 4>& from, const std::array<Vec3, 4>& to,
                           double relativeTolerance = 1e-7);

// A_j = ∫_quad N_j dA (exact: 2x2 Gauss-Legendre integrates the bilinear
// N_j det J exactly). Σ_j A_j is the quad's area.
std::array<double, 4> shapeFunctionAreas(const std::array<Vec3, 4>& quad);
double quadArea(const std::array<Vec3, 4>& quad);

// Area of a planar polygon (any vertex count, Newell's vector area).
double polygonArea(const Vec3* polygon, int count);

// The point of a planar quad (triangle: q2 == q3) nearest to p, as (s, t) of the isoparametric map.
struct QuadPoint {
  double s = 0, t = 0;
  double distance = 0;
};
QuadPoint nearestQuadPoint(const std::array<Vec3, 4>& quad, const Vec3& p);

// Shape function values N_0..N_3 at (s, t).
std::array<double, 4> shapeFunctions(double s, double t);

}  // namespace radbake
