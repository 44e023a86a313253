"""What the two XY stages (belt-stage, vision-stage) share: their discovery adapter
(:mod:`.discovery`), its words (:mod:`.discovery_words`) and its sessions of one machine
(:mod:`.discovery_sessions`)."""
