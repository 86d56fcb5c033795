#pragma once
// Early-return helpers for Result/Status inside hw's .cpp files (not API).
#include <utility>

#define COLLIDE_HW_CONCAT_(a, b) a##b
#define COLLIDE_HW_CONCAT(a, b) COLLIDE_HW_CONCAT_(a, b)

/// `lhs = value of expr`, or return its Error from the enclosing function.
#define COLLIDE_ASSIGN_OR_RETURN(lhs, expr) \
  COLLIDE_ASSIGN_OR_RETURN_(COLLIDE_HW_CONCAT(collide_result_, __LINE__), lhs, expr)
#define COLLIDE_ASSIGN_OR_RETURN_(tmp, lhs, expr) \
  auto tmp = (expr);                              \
  if (!tmp) return tmp.error();                   \
  lhs = std::move(tmp).value()

/// Return the Error of a failed Status/Result from the enclosing function.
#define COLLIDE_RETURN_IF_ERROR(expr)                                     \
  do {                                                                    \
    if (auto collide_s_ = (expr); !collide_s_) return collide_s_.error(); \
  } while (0)
