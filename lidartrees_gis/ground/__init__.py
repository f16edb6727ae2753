"""Ground: the Kraus & Pfeifer filter (:mod:`.filter`), the DTM texture descriptors
(:mod:`.texture`), and the file-level chains of ``ground`` (:mod:`.chain`) and ``dtm-quality``
(:mod:`.quality`, seed 003)."""
