"""The paper's driving world: a bicycle-model car that merges, brakes or overtakes beside another
car on a 3-lane highway (DESIGN §2-4).  Its Domain is :data:`teaching.domains.driving.domain.DOMAIN`."""
