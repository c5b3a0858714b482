//! Builds liblouis (C, LGPL-2.1+, vendored in liblouis/c at the commit liblouis/README.md names)
//! into the crate: the UEB translation of `pipeline::code`. Only a C compiler is needed.

fn main() {
    let dir = std::path::Path::new("liblouis/c");
    let sources = [
        "compileTranslationTable.c",
        "lou_translateString.c",
        "lou_backTranslateString.c",
        "commonTranslationFunctions.c",
        "metadata.c",
        "pattern.c",
        "logging.c",
        "utils.c",
        "maketable.c",
    ];
    let mut build = cc::Build::new();
    build.include(dir).warnings(false).opt_level(2);
    for s in sources {
        build.file(dir.join(s));
    }
    build.compile("louis");
    println!("cargo::rerun-if-changed=liblouis/c");
}
