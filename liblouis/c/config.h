/* The configuration liblouis's sources need, written for build.rs in place of the one
 * autotools generates: the version, and no compiled-in table folder (tables are named by path). */
#ifndef LOUISCFG_H
#define LOUISCFG_H
#define PACKAGE_VERSION "3.38.0-d1f57dc"
#define TABLESDIR ""
#endif
