#pragma once
/// \file Text helpers: suggestions for a misspelt name ("unknown key 'stifness' (did you mean
/// 'stiffness'?)") and XML attribute escaping.

#include <string>
#include <string_view>
#include <vector>

namespace hpr {

/// Levenshtein distance (insertions, deletions, substitutions; '-' and '_' count as equal).
int edit_distance(std::string_view a, std::string_view b);

/// The candidate nearest to `word`, if it is near enough to be a misspelling (at most 2 edits, or a
/// third of the word's length); empty otherwise.
std::string nearest(std::string_view word, const std::vector<std::string>& candidates);

/// " (did you mean 'x'?)" for the nearest candidate, or "".
std::string did_you_mean(std::string_view word, const std::vector<std::string>& candidates);

/// `s` with &, <, > and " escaped, for an XML attribute value or text.
std::string xml_escape(std::string_view s);

}  // namespace hpr
