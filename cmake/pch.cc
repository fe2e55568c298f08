// The translation unit the precompiled headers are built with
// (precompiled_headers.cmake).
