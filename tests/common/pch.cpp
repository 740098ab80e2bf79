// The translation unit that makes the tests' precompiled header (tests/CMakeLists.txt,
// crosslink_test_pch): the header is all it compiles.
