/* The firmware's calls into SymForce's generated error-state navigation EKF (written by the project;
 * SymForce's code is generated into target/peers/symforce at benchmark time by
 * peers/symforce_codegen.py and never committed).
 *
 * C wrappers over the generated templates for `float`: each takes pointers to float
 * arrays, the state (24 entries, the attitude [x, y, z, w] first), the covariance's packed
 * upper triangle over the 23 tangent coordinates (276, row by row), the input or the
 * measurement, and the noise's diagonal (Q over the tangent, or the sensor's R), and writes
 * the new state and covariance to separate arrays: the generated code reads its inputs
 * while it writes its outputs, so an output must not alias an input.
 *
 * The generated functions take Eigen's fixed-size column vectors, which hold exactly
 * their floats; the arrays are viewed as such vectors in place (an Eigen::Map would not
 * bind to their `const Matrix&` parameters without a copy). Eigen gives these vectors an
 * alignment of 16 bytes on this target, so the caller's arrays must be 16-byte aligned
 * (the firmware's are). */

#include <Eigen/Core>

#include "navigation_predict.h"
#include "navigation_update_gnss.h"
#include "navigation_update_magnetometer.h"

namespace {

constexpr int STATES = 24;
constexpr int TANGENT = 23;
constexpr int PACKED = TANGENT * (TANGENT + 1) / 2;

template <int Rows>
using Vector = Eigen::Matrix<float, Rows, 1>;

static_assert(sizeof(Vector<STATES>) == STATES * sizeof(float), "a vector is its floats");
static_assert(sizeof(Vector<PACKED>) == PACKED * sizeof(float), "a vector is its floats");
static_assert(alignof(Vector<STATES>) <= 16, "the firmware aligns its arrays to 16 bytes");

template <int Rows>
const Vector<Rows>& in(const float* data) {
    return *reinterpret_cast<const Vector<Rows>*>(data);
}

template <int Rows>
Vector<Rows>* out(float* data) {
    return reinterpret_cast<Vector<Rows>*>(data);
}

}  // namespace

extern "C" {

/* x_new = f(x, u) over the interval dt, P_new = F P F' + diag(q) dt, F over the tangent
 * space. */
void symforce_navigation_predict(const float* x, const float* p, const float* u,
                                 const float* q, float dt, float* x_new, float* p_new) {
    sym::NavigationPredict<float>(in<STATES>(x), in<PACKED>(p), in<6>(u), in<TANGENT>(q), dt,
                                  out<STATES>(x_new), out<PACKED>(p_new));
}

/* The GNSS fix y (NED velocity, position), R = diag(r), fused one output at a time,
 * then injected and the covariance reset. */
void symforce_navigation_update_gnss(const float* x, const float* p, const float* y,
                                     const float* r, float* x_new, float* p_new) {
    sym::NavigationUpdateGnss<float>(in<STATES>(x), in<PACKED>(p), in<6>(y), in<6>(r),
                                     out<STATES>(x_new), out<PACKED>(p_new));
}

/* The magnetometer reading y, R = diag(r), fused one output at a time, then injected
 * and the covariance reset. */
void symforce_navigation_update_magnetometer(const float* x, const float* p, const float* y,
                                             const float* r, float* x_new, float* p_new) {
    sym::NavigationUpdateMagnetometer<float>(in<STATES>(x), in<PACKED>(p), in<3>(y),
                                             in<3>(r), out<STATES>(x_new), out<PACKED>(p_new));
}
}
