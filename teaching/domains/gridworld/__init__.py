"""A delivery robot in a small yard: carry the parcel to the drop-off, through or around mud, past
or around the dog, fetching a cart or not (docs/domains.md).  Its Domain is
:data:`teaching.domains.gridworld.domain.DOMAIN`."""
