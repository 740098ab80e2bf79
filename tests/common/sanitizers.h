// Whether the build runs under AddressSanitizer (scripts/test-sanitizers.sh): it brings its own
// malloc, and it slows allocating code paths several times more than others, so tests that count
// allocations, or that compare costs measured in the same run, say so and skip that part.
#pragma once

#if defined(__SANITIZE_ADDRESS__)
#define CROSSLINK_ADDRESS_SANITIZER 1
#elif defined(__has_feature)
#if __has_feature(address_sanitizer)
#define CROSSLINK_ADDRESS_SANITIZER 1
#endif
#endif
#ifndef CROSSLINK_ADDRESS_SANITIZER
#define CROSSLINK_ADDRESS_SANITIZER 0
#endif
