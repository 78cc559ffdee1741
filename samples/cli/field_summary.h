// Human and JSON summaries of a field: header, settings, statistics. Used by `bake` and `info`.
#pragma once

#include <shrefract/field.h>

#include <cstdint>
#include <string>

namespace shrefract::cli {

std::string fieldSummaryText(const Field& field, uint64_t fileBytes);
std::string fieldSummaryJson(const Field& field, uint64_t fileBytes);
std::string jsonEscape(const std::string& s);

}  // namespace shrefract::cli
