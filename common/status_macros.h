// RETURN_IF_ERROR / ASSIGN_OR_RETURN for absl::Status and absl::StatusOr.
#pragma once

#include "absl/status/status.h"
#include "absl/status/statusor.h"

#define TEXFREE_CONCAT_INNER(a, b) a##b
#define TEXFREE_CONCAT(a, b) TEXFREE_CONCAT_INNER(a, b)

#define RETURN_IF_ERROR(expr)                                  \
  do {                                                         \
    if (::absl::Status _texfree_status = (expr); !_texfree_status.ok()) { \
      return _texfree_status;                                  \
    }                                                          \
  } while (0)

#define ASSIGN_OR_RETURN(lhs, expr) \
  TEXFREE_ASSIGN_OR_RETURN_IMPL(TEXFREE_CONCAT(_texfree_or_, __LINE__), lhs, expr)

#define TEXFREE_ASSIGN_OR_RETURN_IMPL(tmp, lhs, expr) \
  auto tmp = (expr);                                  \
  if (!tmp.ok()) return tmp.status();                 \
  lhs = std::move(*tmp)
