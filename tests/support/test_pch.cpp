// The translation unit that compiles the test executables' precompiled
// header (tests/CMakeLists.txt, HAPTICD_TEST_PCH); it has nothing of its own.
