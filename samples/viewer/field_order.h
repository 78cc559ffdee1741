// Run-time SH order for the viewer, done on the host side: a field of order L truncated to order
// L' <= L keeps its first (L'+1)^2 basis layers unchanged. With an orthonormal basis that is what
// evaluating fewer terms of the same expansion means, and the engine's Decompressor then picks the
// pipeline specialized for L' from the object's field.
//
// Why on the host: the engine decompresses every object at the order it was created with
// (Object::fieldOrder()); it has no per-frame order. The viewer therefore re-creates the object
// from a truncated copy when the order changes (an upload of the smaller coefficient image).
#pragma once

#include <shrefract/field.h>
#include <shrefract/result.h>

#include <cstdint>

namespace shrefract::viewer {

// A copy of `field` with order `order`: the first (order+1)^2 coefficient layers (and, for U8, their
// scale and bias tables); settings.order follows. Everything else (atlas, frames, mesh, media,
// statistics) is copied as is. The result passes validateField when `field` does.
// Errors: InvalidArgument when order > field.order or the field is not SH.
Result<Field> truncateOrder(const Field& field, uint32_t order);

}  // namespace shrefract::viewer
