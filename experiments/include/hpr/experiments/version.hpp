#pragma once
/// \file The source the tools were built from, carried by every result a sweep or a tune writes.

namespace hpr::experiments {

/// `git describe --always --dirty` of the source tree at build time ("unknown" outside a checkout).
const char* source_commit();

}  // namespace hpr::experiments
