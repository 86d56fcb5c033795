#include "vision/morphology.hpp"

#include <algorithm>
#include <cstdint>
#include <stdexcept>
#include <type_traits>
#include <vector>

#include "vision/avx2_clones.hpp"

namespace collide::vision {
namespace {

struct Max {
  template <class T>
  T operator()(T a, T b) const {
    return std::max(a, b);
  }
};
struct Min {
  template <class T>
  T operator()(T a, T b) const {
    return std::min(a, b);
  }
};

// A dense h x w array of T, rows contiguous.
template <class T>
struct Plane {
  int h = 0, w = 0;
  std::vector<T> v;
  void resize(int rows, int cols) {
    h = rows, w = cols;
    v.resize(static_cast<std::size_t>(rows) * cols);
  }
  T* row(int i) { return v.data() + static_cast<std::size_t>(i) * w; }
  const T* row(int i) const { return v.data() + static_cast<std::size_t>(i) * w; }
};

// out[x] = op(a[x], b[x]), x < n: one pass the compiler vectorises. Nearly
// all of the closing's time is spent here, so these four are built twice, for
// the baseline instruction set (SSE2: 8 samples a step) and for AVX2 (16),
// and the loader picks the one the processor runs (GCC/Clang target_clones).
#define COLLIDE_PAIRWISE(name, T, expr)                                                          \
  COLLIDE_AVX2_CLONES void name(const T* __restrict a, const T* __restrict b, T* __restrict out, \
                                int n) {                                                         \
    for (int x = 0; x < n; ++x) out[x] = (expr);                                                 \
  }
COLLIDE_PAIRWISE(pairMax8, std::uint8_t, a[x] > b[x] ? a[x] : b[x])
COLLIDE_PAIRWISE(pairMin8, std::uint8_t, a[x] < b[x] ? a[x] : b[x])
COLLIDE_PAIRWISE(pairMax16, std::int16_t, a[x] > b[x] ? a[x] : b[x])
COLLIDE_PAIRWISE(pairMin16, std::int16_t, a[x] < b[x] ? a[x] : b[x])
#undef COLLIDE_PAIRWISE

void pairwise(const std::uint8_t* a, const std::uint8_t* b, std::uint8_t* out, int n, Max) {
  pairMax8(a, b, out, n);
}
void pairwise(const std::uint8_t* a, const std::uint8_t* b, std::uint8_t* out, int n, Min) {
  pairMin8(a, b, out, n);
}
void pairwise(const std::int16_t* a, const std::int16_t* b, std::int16_t* out, int n, Max) {
  pairMax16(a, b, out, n);
}
void pairwise(const std::int16_t* a, const std::int16_t* b, std::int16_t* out, int n, Min) {
  pairMin16(a, b, out, n);
}

// out row i = op over in rows i - a .. i + a (rows beyond the ends repeat the
// end rows). Rows of the padded sequence P (j = 0 .. h + 2a - 1, P[j] =
// in[clamp(j - a)]) are cut into blocks of k = 2a + 1; within a block the
// running op from its start (pre) and from its end (suf) give any window of
// k rows as op(suf[i], pre[i + k - 1]).
template <class T, class Op>
void windowRows(const Plane<T>& in, int a, Plane<T>& out, Plane<T>& pre, Plane<T>& suf, Op op) {
  const int h = in.h, w = in.w, k = 2 * a + 1, n = h + 2 * a;
  const auto padded = [&](int j) { return in.row(std::clamp(j - a, 0, h - 1)); };
  pre.resize(n, w);
  suf.resize(n, w);
  for (int j = 0; j < n; ++j) {
    const T* p = padded(j);
    T* g = pre.row(j);
    if (j % k == 0) {
      std::copy(p, p + w, g);
    } else {
      pairwise(pre.row(j - 1), p, g, w, op);
    }
  }
  for (int j = n - 1; j >= 0; --j) {
    const T* p = padded(j);
    T* s = suf.row(j);
    if (j == n - 1 || (j + 1) % k == 0) {
      std::copy(p, p + w, s);
    } else {
      pairwise(suf.row(j + 1), p, s, w, op);
    }
  }
  out.resize(h, w);
  for (int i = 0; i < h; ++i) pairwise(suf.row(i), pre.row(i + k - 1), out.row(i), w, op);
}

// Each row's op over columns x - a .. x + a (columns beyond the ends repeat
// the end columns), in place. The rows are padded (length n = w + 2a) into
// one flat plane; windows of 2, 4, 8, ... columns follow by doubling, up to
// the largest power of two P within the window's k = 2a + 1, and the window
// is then the op of the two windows of P starting at its two ends (they
// overlap, which max and min do not mind). Each doubling runs over the whole
// plane at once (long loops): position j of a row holds its row's window
// wherever that window ends within the row (j <= n - len); positions past it
// mix in the next row and are never read for an output.
template <class T, class Op>
void windowColumns(Plane<T>& img, int a, std::vector<T>& ping, std::vector<T>& pong, Op op) {
  const int w = img.w, h = img.h, n = w + 2 * a, k = 2 * a + 1;
  const std::size_t total = static_cast<std::size_t>(n) * h;
  ping.resize(total);
  pong.resize(total);
  for (int i = 0; i < h; ++i) {
    const T* r = img.row(i);
    T* p = ping.data() + static_cast<std::size_t>(i) * n;
    std::fill(p, p + a, r[0]);
    std::copy(r, r + w, p + a);
    std::fill(p + a + w, p + n, r[w - 1]);
  }
  T* cur = ping.data();
  T* next = pong.data();
  int len = 1;  // cur[j] = op over padded columns j .. j + len - 1
  for (; 2 * len <= k; len *= 2) {
    pairwise(cur, cur + len, next, static_cast<int>(total) - len, op);
    std::swap(cur, next);
  }
  for (int i = 0; i < h; ++i) {
    const T* c = cur + static_cast<std::size_t>(i) * n;
    pairwise(c, c + (k - len), img.row(i), w, op);
  }
}

// The work is done in W, an ordered stand-in for the samples' type T that
// the baseline x86-64 instruction set has a vector max and min for: 16-bit
// samples go signed with their top bit flipped (order kept), 8-bit stay.
template <class T, class W>
W toWork(T v) {
  if constexpr (std::is_same_v<T, W>)
    return v;
  else
    return static_cast<W>(v ^ 0x8000u);
}
template <class T, class W>
T fromWork(W v) {
  if constexpr (std::is_same_v<T, W>)
    return v;
  else
    return static_cast<T>(static_cast<T>(v) ^ 0x8000u);
}

template <class T, class W>
void closeTyped(const cv::Mat& src, int half, cv::Mat& dst) {
  // Scratch kept by each thread from call to call: no allocation, no zeroing.
  thread_local Plane<W> a, b, pre, suf;
  thread_local std::vector<W> ping, pong;
  a.resize(src.rows, src.cols);
  for (int i = 0; i < src.rows; ++i) {
    const T* r = src.ptr<T>(i);
    std::transform(r, r + src.cols, a.row(i), toWork<T, W>);
  }
  // Max and min over a square are separable, the replicated edges too:
  // dilate down the columns, then along the rows; erode along the rows, then
  // down the columns.
  windowRows(a, half, b, pre, suf, Max{});
  windowColumns(b, half, ping, pong, Max{});
  windowColumns(b, half, ping, pong, Min{});
  windowRows(b, half, a, pre, suf, Min{});
  dst.create(src.rows, src.cols, src.type());
  for (int i = 0; i < src.rows; ++i)
    std::transform(a.row(i), a.row(i) + src.cols, dst.ptr<T>(i), fromWork<T, W>);
}

}  // namespace

void closeWithSquare(const cv::Mat& src, int half, cv::Mat& dst) {
  if (half < 0) throw std::invalid_argument("closeWithSquare: negative half width");
  if (src.empty()) {
    dst.release();
    return;
  }
  switch (src.type()) {
    case CV_8UC1: closeTyped<std::uint8_t, std::uint8_t>(src, half, dst); return;
    case CV_16UC1: closeTyped<std::uint16_t, std::int16_t>(src, half, dst); return;
    default:
      throw std::invalid_argument("closeWithSquare: only 8- and 16-bit single-channel images");
  }
}

}  // namespace collide::vision
