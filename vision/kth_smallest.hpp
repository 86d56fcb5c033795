#pragma once
// The k-th smallest of a few hundred doubles, as std::nth_element finds it,
// without its data-dependent branches: the detector's circle fit takes a
// median of its residuals three times per sphere, and std::nth_element's
// mispredicted comparisons made that 8 % of the detector's time.
//
// Quickselect with a three-way partition written without branches: each
// value is stored to both the "smaller" and the "larger" side and only the
// side's count that it belongs to moves on; values equal to the pivot are
// counted, not stored, so ties (and a run of equal values) end the search.

#include <algorithm>
#include <cstddef>
#include <vector>

namespace collide::vision {

/// The value of rank k (0-based) of the n values at `v`; `v`'s contents are
/// overwritten (the values move between it and `scratch`, which is resized
/// to n and may be reused between calls).
/// k < n; NaNs are not allowed.
inline double kthSmallest(double* v, std::size_t n, std::size_t k, std::vector<double>& scratch) {
  scratch.resize(n);
  double* const buffers[2] = {v, scratch.data()};
  int in = 0;  // which buffer the values left are in
  double* src = v;
  std::size_t len = n;
  while (len > 24) {
    // Median of three as the pivot.
    double a = src[0], b = src[len / 2], c = src[len - 1];
    if (a > b) std::swap(a, b);
    if (b > c) std::swap(b, c);
    if (a > b) std::swap(a, b);
    const double pivot = b;
    double* dst = buffers[1 - in];
    // Smaller values fill dst from the front, larger ones from the back.
    std::size_t lo = 0, hi = 0;
    for (std::size_t i = 0; i < len; ++i) {
      const double x = src[i];
      dst[lo] = x;
      dst[len - 1 - hi] = x;
      lo += x < pivot;
      hi += x > pivot;
    }
    if (k < lo) {
      len = lo;
    } else if (k >= len - hi) {
      k -= len - hi;
      dst += len - hi;
      len = hi;
    } else {
      return pivot;
    }
    src = dst;
    in = 1 - in;
  }
  // Insertion sort of the few left.
  for (std::size_t i = 1; i < len; ++i) {
    const double x = src[i];
    std::size_t j = i;
    for (; j > 0 && src[j - 1] > x; --j) src[j] = src[j - 1];
    src[j] = x;
  }
  return src[k];
}

}  // namespace collide::vision
