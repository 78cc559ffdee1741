// What encodeCoefficients shares with validateField (field_validation.cpp). Private to
// engine/src/field.
#pragma once

#include <shrefract/field.h>
#include <shrefract/result.h>

namespace shrefract::fieldfile {

// The encoding's parameters, channels and (Pca) basis: what every decoder relies on. Errors are
// CorruptData, as validateField's.
Result<void> validateEncoding(const Field& field);

}  // namespace shrefract::fieldfile
