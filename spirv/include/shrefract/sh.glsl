// Real orthonormal spherical harmonics in GLSL: the same basis, index and recurrences as
// engine/include/shrefract/sh.h (see docs/technique.md for the convention:
// i = l*l + l + m, z is the pole, m > 0 ~ cos(m phi), m < 0 ~ sin(|m| phi), no Condon-Shortley
// phase; order 2 is 0.282095, 0.488603 (y, z, x), 1.092548 (xy, yz, xz), 0.315392 (3z^2 - 1),
// 0.546274 (x^2 - y^2)).
//
// Two ways to use it:
// - Streaming, for sums such as sum_i c_i Y_i(w) without storing the Y_i:
//       #define ACCUMULATE(i, y) result += coeffs[i] * (y)
//       SH_FOR_EACH_BASIS(w, order, ACCUMULATE)
//   VISIT(i, y) is called once per basis function with i an int and y a float, as a statement,
//   in an order that is NOT increasing i (by m, then l). `order` may be a specialization constant;
//   with a constant order the loops can be unrolled and the per-step constants folded.
// - Filling an array: define SH_GLSL_MAX_BASIS (at least shBasisCount(order)) before including
//   this file, then call shEvaluate(w, order, Y). Entries past shBasisCount(order) are undefined.
//
// The direction need not be unit length; it is normalized, and the zero vector (or one so short
// that its squared length underflows, |dir| < ~1e-19) is treated as +z.
// Precision: the per-step normalization constants are computed in float at run time (one sqrt and
// one division per basis function); the result matches the CPU double evaluation within 1e-5
// absolute up to order 20 (tests/sh/sh_gpu_test.cpp; lavapipe measures 3.3e-6 at order 20).
//
// Names starting with sh_ and ending with _ are reserved for the macro's locals.
#ifndef SHREFRACT_SH_GLSL
#define SHREFRACT_SH_GLSL

int shBasisCount(int order) { return (order + 1) * (order + 1); }

int shIndex(int l, int m) { return l * l + l + m; }

// A direction prepared for the recurrences: unit (x, y, z), s = sign(z) (+1 at z = 0) and
// v = z - s computed without cancellation as -s (x^2 + y^2) / (1 + |z|).
struct ShDirection {
  float x;
  float y;
  float z;
  float s;
  float v;
};

ShDirection shPrepareDirection(vec3 dir) {
  float len2 = dot(dir, dir);
  vec3 d = len2 > 0.0 ? dir * inversesqrt(len2) : vec3(0.0, 0.0, 1.0);
  ShDirection r;
  r.x = d.x;
  r.y = d.y;
  r.z = d.z;
  r.s = d.z < 0.0 ? -1.0 : 1.0;
  r.v = -r.s * (d.x * d.x + d.y * d.y) / (1.0 + abs(d.z));
  return r;
}

// d_m: Pbar_m^m = d_m Pbar_{m-1}^{m-1}; sqrt(2) (the m != 0 normalization) is folded in at m = 1.
float shDiagonalFactor(int m) {
  float f = sqrt(float(2 * m + 1) / float(2 * m));
  return m == 1 ? f * 1.41421356237309515 : f;
}

// g_lm = sqrt((2l+1) / ((2l-1)(l-m)(l+m))); a = (2l-1) g, c = (l-1-m) g, t = (l+m) g.
// The integer products stay exact in float for l < 200.
float shStepFactor(int l, int m) {
  return sqrt(float(2 * l + 1) / float((2 * l - 1) * (l - m) * (l + m)));
}

// The recurrence, on values of type T (float, or vec4 for four directions at once) and a prepared
// direction DIR (ShDirection or ShDirection4): the one implementation both evaluators expand. With
// p = Pbar_{l-1}^m, d = D_{l-1}, one step in l is
//   d = a v p + s c d;  p = s t p + d
// and Y_l^{+m} = p C_m, Y_l^{-m} = p S_m with C_m + i S_m = (x + i y)^m.
#define SH_RECURRENCE_(T, DIR, order, VISIT)                                  \
  {                                                                           \
    int sh_order_ = (order);                                                  \
    T sh_pmm_ = T(0.282094791773878143); /* Pbar_0^0 = 1/sqrt(4 pi) */        \
    T sh_cm_ = T(1.0);                                                        \
    T sh_sm_ = T(0.0);                                                        \
    for (int sh_m_ = 0; sh_m_ <= sh_order_; ++sh_m_) {                        \
      if (sh_m_ > 0) {                                                        \
        T sh_cn_ = DIR.x * sh_cm_ - DIR.y * sh_sm_;                           \
        sh_sm_ = DIR.x * sh_sm_ + DIR.y * sh_cm_;                             \
        sh_cm_ = sh_cn_;                                                      \
        sh_pmm_ *= shDiagonalFactor(sh_m_);                                   \
      }                                                                       \
      {                                                                       \
        int sh_i_ = sh_m_ * sh_m_ + 2 * sh_m_;                                \
        T sh_y_ = sh_pmm_ * sh_cm_;                                           \
        VISIT(sh_i_, sh_y_);                                                  \
      }                                                                       \
      if (sh_m_ > 0) {                                                        \
        int sh_i_ = sh_m_ * sh_m_;                                            \
        T sh_y_ = sh_pmm_ * sh_sm_;                                           \
        VISIT(sh_i_, sh_y_);                                                  \
      }                                                                       \
      T sh_p_ = sh_pmm_;                                                      \
      T sh_dl_ = T(0.0);                                                      \
      for (int sh_l_ = sh_m_ + 1; sh_l_ <= sh_order_; ++sh_l_) {              \
        float sh_g_ = shStepFactor(sh_l_, sh_m_);                             \
        sh_dl_ = float(2 * sh_l_ - 1) * sh_g_ * DIR.v * sh_p_ +               \
                 DIR.s * float(sh_l_ - 1 - sh_m_) * sh_g_ * sh_dl_;           \
        sh_p_ = DIR.s * float(sh_l_ + sh_m_) * sh_g_ * sh_p_ + sh_dl_;        \
        {                                                                     \
          int sh_i_ = sh_l_ * sh_l_ + sh_l_ + sh_m_;                          \
          T sh_y_ = sh_p_ * sh_cm_;                                           \
          VISIT(sh_i_, sh_y_);                                                \
        }                                                                     \
        if (sh_m_ > 0) {                                                      \
          int sh_i_ = sh_l_ * sh_l_ + sh_l_ - sh_m_;                          \
          T sh_y_ = sh_p_ * sh_sm_;                                           \
          VISIT(sh_i_, sh_y_);                                                \
        }                                                                     \
      }                                                                       \
    }                                                                         \
  }

// Streaming evaluator (see the top of this file).
#define SH_FOR_EACH_BASIS(dir, order, VISIT)                                  \
  {                                                                           \
    ShDirection sh_d_ = shPrepareDirection(dir);                              \
    SH_RECURRENCE_(float, sh_d_, order, VISIT)                                \
  }

// Four directions at once, as the components of vec4s (SoA: direction j is (x[j], y[j], z[j])):
// the same recurrence and visiting order, with VISIT(i, y) given a vec4 y (Y_i of each direction).
// For a consumer that shares its work per basis function between four evaluations (one memory read
// of four samples' coefficients, say). Each component performs the operations of SH_FOR_EACH_BASIS
// on its direction (the squared length is summed as x*x + y*y + z*z rather than with dot()).
struct ShDirection4 {
  vec4 x;
  vec4 y;
  vec4 z;
  vec4 s;
  vec4 v;
};

ShDirection4 shPrepareDirection4(vec4 x, vec4 y, vec4 z) {
  vec4 len2 = x * x + y * y + z * z;
  bvec4 zero = lessThanEqual(len2, vec4(0.0));
  vec4 inv = inversesqrt(mix(len2, vec4(1.0), zero));
  ShDirection4 r;
  r.x = mix(x * inv, vec4(0.0), zero);
  r.y = mix(y * inv, vec4(0.0), zero);
  r.z = mix(z * inv, vec4(1.0), zero);
  r.s = mix(vec4(1.0), vec4(-1.0), lessThan(r.z, vec4(0.0)));
  r.v = -r.s * (r.x * r.x + r.y * r.y) / (1.0 + abs(r.z));
  return r;
}

#define SH_FOR_EACH_BASIS_X4(dirX, dirY, dirZ, order, VISIT)                  \
  {                                                                           \
    ShDirection4 sh_d_ = shPrepareDirection4(dirX, dirY, dirZ);               \
    SH_RECURRENCE_(vec4, sh_d_, order, VISIT)                                 \
  }

#ifdef SH_GLSL_MAX_BASIS
#define SH_STORE_BASIS_(i, y) Y[i] = (y)
// Fills Y[0 .. shBasisCount(order)-1]. Precondition: shBasisCount(order) <= SH_GLSL_MAX_BASIS.
void shEvaluate(vec3 dir, int order, out float Y[SH_GLSL_MAX_BASIS]) {
  SH_FOR_EACH_BASIS(dir, order, SH_STORE_BASIS_)
}
#undef SH_STORE_BASIS_
#endif

#endif  // SHREFRACT_SH_GLSL
