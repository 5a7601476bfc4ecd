#pragma once
// Counts heap allocations of the whole test program (operator new is replaced in
// allocation_counter.cpp), for tests that check a hot path allocates nothing.
namespace hpr::test {
long allocations();
/// Bytes requested from operator new so far (never decreases).
long allocated_bytes();
}
