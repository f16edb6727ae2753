"""What is shown to people: legend classes (:mod:`.classes`, standard library only), the quick
look (:mod:`.quicklook`), small plots (:mod:`.plots`) and the accuracy of detected trees
against reference trees (:mod:`.evaluate`)."""
