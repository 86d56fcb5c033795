#pragma once
// COLLIDE_ASAN is defined when this translation unit is built with
// AddressSanitizer: gcc says so with __SANITIZE_ADDRESS__, clang through
// __has_feature(address_sanitizer). The reader process and its tests use it.

#if defined(__SANITIZE_ADDRESS__)
#define COLLIDE_ASAN 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define COLLIDE_ASAN 1
#endif
#endif
