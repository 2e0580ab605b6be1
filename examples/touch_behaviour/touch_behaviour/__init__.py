"""An example behaviour node for social_touch (see the README's "Writing a behaviour node")."""
