// The one file of the precompiled-header owners (cmake/hdabenchPrecompiledHeaders.cmake):
// they compile their header set and nothing else.
